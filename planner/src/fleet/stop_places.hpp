#pragma once
/// Where a robot whose route meets another robot can stop and let it pass: on its leg before
/// the meeting, or beside it (a bay off an aisle), out of that robot's whole way; and where a
/// robot stopped at a point would stand on the ground. Used to add stops to a route and to find
/// the place a robot makes way at its goal (docs/design.md, "Fleets", steps 4 and 5).
#include <cstdint>
#include <functional>
#include <optional>
#include <span>

#include <Eigen/Core>

#include "strata/fleet/traffic.hpp"
#include "strata/planner.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata::fleet_internal {

/// An added stop keeps at least this far from the ends of its leg [m], and points added to a
/// route at least this far apart (two route points on one graph node are refused).
inline constexpr double kMinStopSpacingM = 0.5;

/// A stop to add to a route, found beside or on one of its legs.
struct AddedStop {
  double leg_time_s = 0;  ///< When the leg, without waits, is where the stop was found [s].
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
};

/// A place to wait at before `leg` (leaving at `departure_ns`) meets another robot as `met`
/// says, for that robot to pass: the leg's latest point before the meeting, or a point beside
/// it (kStopSideOffsetsM to either side, where `stands` finds ground), that keeps
/// kStopClearanceM more than the limit from the whole of that robot's way from the departure
/// on; at least kMinStopSpacingM from both ends of the leg. None when there is no such place,
/// or `should_stop` (may be empty; polled at every point of the leg tried) says stop.
std::optional<AddedStop> StopBefore(
    const Trajectory& leg, std::int64_t departure_ns, const TrafficConflict& met,
    const Traffic& traffic,
    const std::function<std::optional<Eigen::Vector3d>(const Eigen::Vector3d&)>& stands,
    const std::function<bool()>& should_stop);

/// Where a robot of `profile` would stand when stopped at `p`: p snapped onto its `graph`
/// (as a goal is, within kStandingSnapM, also in height), connected to node `route_node`, outside
/// `zones` (the map's and the request's, CollectKeepOut). None when it cannot stand there.
std::optional<Eigen::Vector3d> StandingPoint(const SurfaceGraph& graph,
                                             std::span<const KeepOutZone> zones,
                                             const RobotProfile& profile, int route_node,
                                             const Eigen::Vector3d& p);

}  // namespace strata::fleet_internal
