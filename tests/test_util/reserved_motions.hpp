#pragma once
/// Other robots' committed motions for tests of the fleet planner's parts. Header-only, test
/// code only.
#include <cstdint>
#include <string>
#include <utility>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/fleet/traffic.hpp"

namespace strata::test_util {

/// Robot `robot`'s committed motion: `trajectory` from `start_ns`, then parked at its end for
/// 600 s (longer than any test looks).
inline ReservedMotion Reserved(const std::string& robot, std::int64_t start_ns,
                               Trajectory trajectory) {
  ReservedMotion reserved;
  reserved.robot_id = robot;
  reserved.motion.start_ns = start_ns;
  reserved.motion.trajectory = std::move(trajectory);
  reserved.motion.end_ns = AddSeconds(reserved.motion.ArrivalNs(), 600);
  return reserved;
}

}  // namespace strata::test_util
