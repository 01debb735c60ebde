#include "baselines/krusi_terrain.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "baselines/footprint_check.hpp"
#include "baselines/local_plane.hpp"

namespace strata::baselines {

KrusiTerrain::KrusiTerrain(const CloudSearch& search, const BaselineRobot& robot,
                           const KrusiTerrainParams& params, double spacing_m)
    : search_(search), robot_(robot), params_(params), spacing_m_(spacing_m) {
  support_radius_m_ = std::max(robot.footprint_radius_m, params.support_spacings * spacing_m);
  // One radius query must hold the footprint check's column and the ground window below it.
  const double tilt_rise = support_radius_m_ * std::tan(robot.max_tilt_rad);
  const double low = -params.ground_window_m - robot.max_step_m - tilt_rise;
  const double high = params.ground_window_m + robot.clearance_m() + tilt_rise;
  query_radius_m_ = std::hypot(support_radius_m_, 0.5 * (high - low));
  center_lift_m_ = static_cast<float>(0.5 * (high + low));
}

std::optional<float> KrusiTerrain::GroundUnder(const Eigen::Vector3d& reference_m) const {
  thread_local std::vector<int> indices;
  thread_local std::vector<int> ground;
  thread_local PointCloud neighbours;
  const Eigen::Vector3f guess =
      (reference_m - Eigen::Vector3d(0, 0, robot_.reference_height_m)).cast<float>();
  search_.Radius(guess + Eigen::Vector3f(0, 0, center_lift_m_), query_radius_m_, &indices);
  const float support_r2 = static_cast<float>(support_radius_m_ * support_radius_m_);
  const float window = static_cast<float>(params_.ground_window_m);
  ground.clear();
  neighbours.clear();
  for (const int i : indices) {
    const Eigen::Vector3f& q = search_.point(i);
    neighbours.push_back(q);
    const Eigen::Vector2f d = q.head<2>() - guess.head<2>();
    if (d.squaredNorm() <= support_r2 && std::abs(q.z() - guess.z()) <= window) {
      ground.push_back(static_cast<int>(neighbours.size() - 1));
    }
  }
  // Only the top layer is ground: a point with another one right above it (closer than the
  // point spacing horizontally, higher than a slope could explain) is the underside of a slab
  // or the foot of a wall, and would tilt the plane fit.
  const float near2 = static_cast<float>(spacing_m_ * spacing_m_);
  const float band =
      static_cast<float>(std::max(0.08, 2 * spacing_m_ * std::tan(robot_.max_tilt_rad)));
  thread_local std::vector<int> all_ground;
  all_ground = ground;
  std::erase_if(ground, [&](int g) {
    const Eigen::Vector3f& q = neighbours[g];
    return std::any_of(all_ground.begin(), all_ground.end(), [&](int h) {
      const Eigen::Vector3f& p = neighbours[h];
      return p.z() - q.z() > band && (p.head<2>() - q.head<2>()).squaredNorm() <= near2;
    });
  });
  if (static_cast<int>(ground.size()) < params_.min_patch_points) return std::nullopt;
  const LocalPlane plane = FitLocalPlane(neighbours, ground);
  if (!plane.valid || plane.tilt_rad() > robot_.max_tilt_rad ||
      plane.roughness_m > params_.max_roughness_m) {
    return std::nullopt;
  }
  const float ground_z = plane.HeightAt(guess.x(), guess.y());
  if (std::abs(ground_z - guess.z()) > window) return std::nullopt;
  const Eigen::Vector3f foot(guess.x(), guess.y(), ground_z);
  if (!CheckFootprint(foot, plane.normal, neighbours, robot_, support_radius_m_).ok()) {
    return std::nullopt;
  }
  return ground_z;
}

bool KrusiTerrain::MotionValid(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               double* last_valid_fraction) const {
  const int steps =
      std::max(1, static_cast<int>(std::ceil((b - a).norm() / params_.check_resolution_m)));
  const double horizontal_step = (b - a).head<2>().norm() / steps;
  const double max_change = robot_.max_step_m + horizontal_step * std::tan(robot_.max_tilt_rad);
  std::optional<float> previous = GroundUnder(a);
  if (last_valid_fraction != nullptr) *last_valid_fraction = 0;
  if (!previous) return false;
  for (int i = 1; i <= steps; ++i) {
    const std::optional<float> ground = GroundUnder(a + (b - a) * (double(i) / steps));
    if (!ground || std::abs(*ground - *previous) > max_change) return false;
    if (last_valid_fraction != nullptr) *last_valid_fraction = double(i) / steps;
    previous = ground;
  }
  return true;
}

}  // namespace strata::baselines
