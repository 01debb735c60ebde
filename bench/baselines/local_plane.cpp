#include "baselines/local_plane.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace strata::baselines {

float LocalPlane::tilt_rad() const { return std::acos(std::clamp(normal.z(), -1.f, 1.f)); }

float LocalPlane::HeightAt(float x, float y) const {
  if (normal.z() < 1e-3f) return centroid.z();
  return centroid.z() -
         (normal.x() * (x - centroid.x()) + normal.y() * (y - centroid.y())) / normal.z();
}

LocalPlane FitLocalPlane(std::span<const Eigen::Vector3f> points, std::span<const int> indices) {
  LocalPlane plane;
  if (indices.size() < 3) return plane;
  // Centred in double: clouds tens of metres from the origin lose precision in float.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const int i : indices) mean += points[static_cast<std::size_t>(i)].cast<double>();
  mean /= static_cast<double>(indices.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const int i : indices) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(i)].cast<double>() - mean;
    covariance.noalias() += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  if (solver.info() != Eigen::Success) return plane;
  const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // Ascending.
  const double sum = eigenvalues.sum();
  Eigen::Vector3d normal = solver.eigenvectors().col(0);
  if (normal.z() < 0) normal = -normal;
  plane.valid = std::isfinite(normal.z());
  plane.centroid = mean.cast<float>();
  plane.normal = normal.normalized().cast<float>();
  plane.surface_variation = sum > 0 ? static_cast<float>(std::max(0.0, eigenvalues(0)) / sum) : 0.f;
  plane.roughness_m = static_cast<float>(
      std::sqrt(std::max(0.0, eigenvalues(0)) / static_cast<double>(indices.size())));
  return plane;
}

}  // namespace strata::baselines
