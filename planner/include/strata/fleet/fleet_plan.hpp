#pragma once
/// Planning one robot of a fleet against the motions the others have committed (priority by
/// commit order: the robot planned later keeps out of the way of those planned before).
///
/// How (docs/design.md, "Fleets"): other robots parked for the time this plan may take are
/// keep-out zones, which the search and the optimiser go around; the plan is then placed at
/// its departure, and the robot waits, at rest, at its start and at stops along its route for
/// the moving ones to pass (a search over the departures from each stop, hold_schedule.hpp),
/// each departure checked exactly against every motion (traffic.hpp). Where no waits clear
/// the route, a route is searched in space and time over the graph (SIPP: waiting before a
/// lane, pulling into a bay, taking another aisle) and the plan follows it; where waits still
/// do not clear it, a stop is added before what it meets, out of that robot's way, and the
/// route is planned again through it. The trajectory returned is Plan's verified one with the waits
/// inserted as pieces at rest at verified points, checked exactly against every motion.
#include <cstdint>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/fleet/motion_conflict.hpp"
#include "strata/fleet/traffic.hpp"
#include "strata/planner.hpp"
#include "strata/status.hpp"

namespace strata {

struct FleetPlanOptions {
  SeparationRule rule;
  /// Longest the robot may wait for others to pass, at its start and at stops on its way
  /// together [s], in [0, 3600].
  double max_wait_s = 60;
  Status Validate(std::string_view path) const;
};

struct FleetPlanRequest {
  PlanRequest plan;  ///< As for a robot alone on the site.
  /// Absolute time at which the robot is at plan.start and may leave [ns].
  std::int64_t departure_ns = 0;
  /// Until when the robot then stays parked at its goal [ns] (its reservation's lease); the
  /// arrival, if later, takes its place.
  std::int64_t parked_until_ns = 0;
  FleetPlanOptions fleet;
  /// The other robots' committed motions (not this robot's own earlier one).
  std::span<const ReservedMotion> others;
};

/// A wait in a fleet plan: a piece of the trajectory at rest.
struct FleetHold {
  double start_s = 0;     ///< When it begins, from the trajectory's start [s].
  double duration_s = 0;  ///< [s], > 0.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< Where the robot stands [m].
};

struct FleetPlanResult {
  /// The plan; each of `holds` is a piece at rest in its trajectory, and its duration and via
  /// times include them. Its `via` and via times are the request's vias only.
  PlanResult plan;
  FleetMotion motion;            ///< The trajectory at its departure, parked until parked_until_ns.
  double wait_s = 0;             ///< How long the robot waits in all, the sum of `holds` [s].
  std::vector<FleetHold> holds;  ///< In trajectory order; at the start when start_s is 0.
  int stops_added = 0;           ///< Stops on the way added so that the robot could wait.
  int parked_robots_avoided = 0;  ///< Others' parking places planned around as zones.
  int departures_checked = 0;     ///< Departures checked against the traffic.
  /// Times the route was planned: the first, and one more each time robots parked in its way
  /// were found, a route was searched in space and time, or a stop was added (at most 6).
  int plan_rounds = 0;
  /// When the trajectory first reaches the goal, from its start [s]: its duration, or less
  /// when the robot then makes way.
  double arrival_s = 0;
  /// The robot makes way at its goal for a robot that passes there later: after arriving it
  /// holds there, leaves for a place beside the goal, holds there and comes back (the last
  /// two of `holds` and the pieces between them).
  bool makes_way = false;
};

/// Plans `request` among the others' motions. Fails as Plan does, and with
/// kReservationConflict naming the robot in the way, when and where: the start is already
/// within reach of a robot parked there, the goal is where another robot stays parked, or no
/// waits up to max_wait_s in all clear every motion. `should_stop` as for Plan.
Expected<FleetPlanResult> PlanAmongTraffic(const PlanningMap& map, const FleetPlanRequest& request,
                                           const std::function<bool()>& should_stop = {});

}  // namespace strata
