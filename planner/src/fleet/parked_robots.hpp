#pragma once
/// Other robots parked where a route passes: which stand in its way for longer than any wait
/// could clear (so the route goes around them), and the keep-out zone a plan goes around
/// (docs/design.md, "Fleets", step 2).
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "strata/fleet/traffic.hpp"
#include "strata/planning/keep_out.hpp"

namespace strata::fleet_internal {

/// A body standing at `state` (its trajectory's `dimension`) from `from_ns` until `until_ns`.
FleetMotion Standing(const StateVector& state, int dimension, const FleetBody& body,
                     std::int64_t from_ns, std::int64_t until_ns);

/// A zone around where `other` stays parked: a polygon around the disc of its radius plus
/// the pair's separation (a robot whose footprint stays out of it keeps the limit), over the
/// height its body takes there. Where the robot's footprint at one of its `ends` (start, goal)
/// is clear of that disc but not of the polygon, the polygon turns the middle of an edge
/// towards that end and keeps half the room left as its margin: the end stays outside and the
/// disc inside. (Refusing such a start as if the other robot stood on it refused a robot
/// replanned on its way that had passed a parked one 1 cm clear.)
Prism ParkedZone(const FleetMotion& other, const SeparationRule& rule, const RobotProfile& profile,
                 std::span<const Eigen::Vector3d> ends);

/// Robots parked in the way of a route (ParkedInTheWay).
struct ParkedInWay {
  std::vector<std::size_t> robots;  ///< Indices into the traffic's others.
  /// When the route first comes within reach of one of them [ns]; max when there are none.
  std::int64_t first_near_ns = std::numeric_limits<std::int64_t>::max();
};

/// The robots, none already `settled`, that stand parked where `motion` (the route without
/// waits) passes, from before the robot could have passed with any wait up to `max_wait_s`
/// until after: waiting cannot clear them, going around can. (Where the route passes before
/// such a robot arrives, it is planned around it all the same.) `reach_m` widens the separation
/// for a way the trajectory will not follow closely.
ParkedInWay ParkedInTheWay(const FleetMotion& motion, const Traffic& traffic, double max_wait_s,
                           const std::vector<bool>& settled, double reach_m = 0);

}  // namespace strata::fleet_internal
