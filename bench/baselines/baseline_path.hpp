#pragma once
// What a baseline returns for one query: a point path, no timing along it.

#include <vector>

#include <Eigen/Core>

namespace strata::baselines {

struct BaselinePath {
  /// The robot's reference point along the path (ground + reference height) [m], start first.
  std::vector<Eigen::Vector3d> points_m;
  double start_snap_m = 0;  ///< How far the start moved to reach the method's valid ground [m].
  double goal_snap_m = 0;   ///< Same for the goal [m].
};

}  // namespace strata::baselines
