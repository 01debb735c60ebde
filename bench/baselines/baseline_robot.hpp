#pragma once
// The robot limits both baselines hold a plan to: the same numbers as a Strata RobotProfile,
// so a comparison never gives one method a smaller robot than another.

#include <Eigen/Core>

#include "strata/planning/robot_profile.hpp"

namespace strata::baselines {

struct BaselineRobot {
  double footprint_radius_m = 0.3;  ///< Radius of the footprint disc [m], > 0.
  double max_tilt_rad = 20.0 * 3.14159265358979323846 / 180.0;  ///< Steepest ground [rad].
  double max_step_m = 0.15;         ///< Highest step between neighbouring places [m], >= 0.
  double body_height_m = 0.5;       ///< Free height the body needs above the ground [m].
  double headroom_m = 0.05;         ///< Extra free space above the body [m], >= 0.
  double reference_height_m = 0.3;  ///< Path points lie this far above the ground [m].

  /// The limits of a Strata profile. The baselines have no height freedom (paper Table 1):
  /// for an active-height robot (the biped) they plan for its preferred body height, the
  /// height it drives at, as a fixed-height planner would.
  static BaselineRobot FromProfile(const RobotProfile& profile) {
    BaselineRobot r;
    r.footprint_radius_m = profile.footprint_radius_m;
    r.max_tilt_rad = profile.max_tilt_rad;
    r.max_step_m = profile.max_step_m;
    r.body_height_m = profile.body_height_m;
    r.headroom_m = profile.headroom_m;
    r.reference_height_m = profile.reference_height_m;
    return r;
  }
  /// Height above the ground that must be free of points [m].
  double clearance_m() const { return body_height_m + headroom_m; }
};

}  // namespace strata::baselines
