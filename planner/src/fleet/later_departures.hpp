#pragma once
/// Later departures (docs/design.md, "Fleets", step 8): a request refused at its departure is
/// planned again a little later, the robot holding at its start until then.
#include <functional>

#include "strata/fleet/fleet_plan.hpp"
#include "strata/status.hpp"

namespace strata::fleet_internal {

/// Plans one robot at the departure of the request it is given (commit order, then replanning
/// others, as PlanAmongTraffic does at the request's own departure); its legs through `legs`.
using DeparturePlanner =
    std::function<Expected<FleetPlanResult>(const FleetPlanRequest&, LegCache* legs)>;

/// `request`, refused with `refusal` at its departure, planned by `plan_at` for a departure 5 s
/// later, then 10, 20 and 30 s later (within fleet.max_wait_s, which the hold counts against),
/// until one plans, the robot holding at its start from its departure until then: the hold is
/// checked exactly against `request.others` and joins the wait the later plan begins with.
/// Tried only for a refusal for a conflict (kReservationConflict), a request that may replan
/// others (fleet.replan.max_robots > 0) and a start at rest. `refusal` itself otherwise, and
/// when every try is refused, a robot passes the start during the hold, or a try is cancelled
/// or runs out of time. Tries share `legs`.
Expected<FleetPlanResult> PlanLeavingLater(const FleetPlanRequest& request, Error refusal,
                                           LegCache* legs, const DeparturePlanner& plan_at);

}  // namespace strata::fleet_internal
