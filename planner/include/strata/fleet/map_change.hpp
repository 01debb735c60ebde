#pragma once
/// Whether a committed motion is still safe on another version of its map: a robot's
/// reservation was verified on the version it was planned on, and a scan or an edit since may
/// have put a pallet on its path, cut a hole under it or closed an aisle (docs/design.md §19).

#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/planner.hpp"

namespace strata {

/// The first instant a motion is not safe on a map.
struct UnsafeMotion {
  std::int64_t time_ns = 0;                              ///< Absolute time [ns].
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< The reference point then [m].
  std::string reason;  ///< What is wrong there, in words with the figures.
};

/// The first instant from `from_ns` on (the motion's start if later) at which `motion` breaks
/// one of the map rules VerifyTrajectory checks with `config` on `map`: its reference point
/// closer than min_obstacle_distance_m to an obstacle, no ground under it or the ground off its
/// height by more than the ground tolerance (0.75 quanta on a voxelised map, if more), or its
/// footprint in one of the map's keep-out zones (the body's radius, reference height and body
/// height standing for the robot's profile). Checked at samples at most `spacing_m` of motion
/// apart (and 0.5 s), its parked end included: unlike VerifyTrajectory, nothing is proven
/// between samples, and the robot's own limits and graph are not checked (the reservation
/// does not hold its profile). nullopt when every sample is safe or the motion has ended.
std::optional<UnsafeMotion> FirstUnsafeOnMap(const PlanningMap& map, const FleetMotion& motion,
                                             std::int64_t from_ns,
                                             const VerifierConfig& config = {},
                                             double spacing_m = 0.05);

}  // namespace strata
