#pragma once
/// Time stretching: the same path, traversed more slowly. Scaling every piece duration by k
/// (> 1) divides speeds by k and accelerations by k² wherever the boundary velocity and
/// acceleration are zero (the minimum-jerk trajectory through the same joints with durations
/// k·T is p(t/k)), so a trajectory whose only fault is a speed or an acceleration a few
/// percent over a bound becomes feasible without moving it an inch. With a moving start or
/// goal (a replan), the boundary states are kept and the pieces near them change a little:
/// verification decides.
#include <Eigen/Core>

#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata {

/// The largest horizontal and vertical speed and acceleration of the x, y, z path.
struct DynamicPeaks {
  double speed_horizontal_mps = 0;
  double speed_vertical_mps = 0;
  double accel_horizontal_mps2 = 0;
  double accel_vertical_mps2 = 0;
};

/// Peaks over samples at most `max_step_s` apart in every piece (> 0), both ends included.
DynamicPeaks SampleDynamicPeaks(const Trajectory& trajectory, double max_step_s);

/// The smallest k >= 1 for which peaks / k (speeds) and peaks / k² (accelerations) are within
/// `fraction` (in (0, 1]) of the profile's bounds.
double RequiredTimeScale(const DynamicPeaks& peaks, const RobotProfile& profile, double fraction);

/// The trajectory through the same joints with every duration times k (> 0), re-solved as a
/// minimum-jerk MINCO trajectory with the boundary states `head_pva` and `tail_pva` (dim×3:
/// position, velocity, acceleration). With zero boundary velocity and acceleration it is
/// exactly p(t/k).
Trajectory StretchTime(const Trajectory& trajectory, double k, const Eigen::MatrixXd& head_pva,
                       const Eigen::MatrixXd& tail_pva);

}  // namespace strata
