#pragma once
/// Local plane fit for the safety penalty field (paper Sec. IV): RANSAC, then least squares on
/// the inliers.

#include <memory>
#include <span>

#include <Eigen/Core>

namespace strata {

/// A fitted plane.
struct PlaneFit {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();  ///< Centroid of the inliers p_c [m].
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   ///< Unit normal, n_z >= 0.
  double tilt_rad = 0.0;  ///< φ = angle(normal, z), folded so that φ = min(φ, π − φ) [rad].
  int inlier_count = 0;   ///< Points within the inlier distance of the plane.
};

/// Fits planes to local patches. RANSAC (PCL's sample consensus, at most `ransac_iterations`
/// hypotheses, inlier band ±`inlier_distance_m`) picks the dominant plane, then a
/// least-squares fit on its inliers refines it. When the least-squares plane of all points
/// already holds every point within the band there is no outlier to reject, so RANSAC is
/// skipped: on clean floors and ramps (most patches) a fit costs one 3×3 eigensolve.
/// One fitter keeps its buffers between fits; use one per thread. Results do not depend on
/// which fitter (thread) fits a patch.
class LocalPlaneFitter {
 public:
  LocalPlaneFitter(double inlier_distance_m, int ransac_iterations);
  ~LocalPlaneFitter();
  LocalPlaneFitter(const LocalPlaneFitter&) = delete;
  LocalPlaneFitter& operator=(const LocalPlaneFitter&) = delete;

  /// Fits `points`; inlier_count = 0 for fewer than 3 points or a degenerate (collinear) patch.
  /// Optional `weights` (empty, or one > 0 per point) weight the least-squares fits (RANSAC's
  /// vote stays one point, one vote).
  PlaneFit Fit(std::span<const Eigen::Vector3f> points, std::span<const float> weights = {});

 private:
  struct Ransac;  // Buffers; PCL types stay out of this header.
  double inlier_distance_m_;
  int ransac_iterations_;
  std::unique_ptr<Ransac> ransac_;
};

/// One-off convenience: LocalPlaneFitter(inlier_distance_m, ransac_iterations).Fit(points).
PlaneFit FitLocalPlane(std::span<const Eigen::Vector3f> points, double inlier_distance_m,
                       int ransac_iterations);

}  // namespace strata
