#pragma once
// PCA of a local neighbourhood: the plane both baselines read the terrain from. For the
// Liu-style baseline this stands in for tensor voting's surface saliency (the same
// eigen-analysis of a second-moment tensor, without the voting fields).

#include <span>

#include <Eigen/Core>

namespace strata::baselines {

struct LocalPlane {
  bool valid = false;                                  ///< At least three points and a finite fit.
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();  ///< Mean of the points [m].
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();   ///< Unit, oriented with z >= 0.
  /// Surface variation λ0/(λ0+λ1+λ2) of the covariance [-], in [0, 1/3]: 0 for a plane.
  float surface_variation = 0;
  /// Root mean square distance of the points from the plane [m] (sqrt(λ0 / n)): the
  /// roughness both baselines threshold, in metres so it compares with the robot's step.
  float roughness_m = 0;
  /// Angle between the normal and vertical [rad].
  float tilt_rad() const;
  /// Height of the plane above (x, y) [m] (the centroid's z for a vertical plane).
  float HeightAt(float x, float y) const;
};

/// Fits a plane to points[indices[i]] by PCA (least squares, smallest eigenvector).
LocalPlane FitLocalPlane(std::span<const Eigen::Vector3f> points, std::span<const int> indices);

}  // namespace strata::baselines
