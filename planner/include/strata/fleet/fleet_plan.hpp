#pragma once
/// Planning one robot of a fleet against the motions the others have committed (priority by
/// commit order: the robot planned later keeps out of the way of those planned before).
///
/// How (docs/design.md, "Fleets"): other robots parked for the time this plan may take are
/// keep-out zones, which the search and the optimiser go around; the plan is then placed at
/// its departure and checked exactly against every other motion (traffic.hpp). When it meets
/// one, the robot waits at its start, holding its position at rest as the trajectory's first
/// piece, for the shortest of a ladder of waits that clears every motion. The trajectory
/// returned is Plan's verified one behind that rest, checked exactly against every motion.
#include <cstdint>
#include <functional>
#include <span>
#include <string_view>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/fleet/motion_conflict.hpp"
#include "strata/fleet/traffic.hpp"
#include "strata/planner.hpp"
#include "strata/status.hpp"

namespace strata {

struct FleetPlanOptions {
  SeparationRule rule;
  /// Longest the robot may wait at its start for others to pass [s], in [0, 3600].
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

struct FleetPlanResult {
  /// The plan; when wait_s > 0 its trajectory begins with a piece of wait_s at rest at the
  /// start, and its duration and via times include it.
  PlanResult plan;
  FleetMotion motion;  ///< The trajectory at its departure, parked until parked_until_ns.
  double wait_s = 0;   ///< How long the robot waits at its start [s].
  int parked_robots_avoided = 0;  ///< Others' parking places planned around as zones.
  int waits_tried = 0;            ///< Waits checked against the traffic, 0 when none needed.
};

/// Plans `request` among the others' motions. Fails as Plan does, and with
/// kReservationConflict naming the robot in the way, when and where: the start is already
/// within reach of a robot parked there, the goal is where another robot stays parked, or no
/// wait up to max_wait_s clears every motion. `should_stop` as for Plan.
Expected<FleetPlanResult> PlanAmongTraffic(const PlanningMap& map, const FleetPlanRequest& request,
                                           const std::function<bool()>& should_stop = {});

}  // namespace strata
