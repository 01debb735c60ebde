#pragma once
/// Replanning the robots in a refused plan's way (ReplanOptions in strata/fleet/fleet_plan.hpp;
/// docs/design.md, "Fleets"): the refused robot goes first, and the robots it was refused for,
/// still on their way, are planned again behind it from where they will be at the notice.
#include <functional>

#include "strata/fleet/fleet_plan.hpp"
#include "strata/status.hpp"

namespace strata::fleet_internal {

/// Plans one robot among the others in commit order, as PlanAmongTraffic does without
/// replanning anyone; through `legs` (LegCache: one robot's profile and options on one map),
/// or through a cache of its own when null.
using CommitOrderPlanner =
    std::function<Expected<FleetPlanResult>(const FleetPlanRequest&, LegCache* legs)>;

/// `request`, which `plan_in_order` refused with `refusal` (kReservationConflict), planned by
/// replanning the robots in its way (ReplanOptions): the result has them in `replanned`. The
/// robot's tries going first share `legs` (those of the refused try; may be null). The
/// refusal itself when the robot it names may not be replanned (not in request.replannable,
/// not yet departed or already arrived by the notice, a 4-D trajectory) or when any of the
/// plans does not succeed; a cancellation or deadline as it comes.
Expected<FleetPlanResult> PlanReplanningOthers(const FleetPlanRequest& request, Error refusal,
                                               LegCache* legs,
                                               const CommitOrderPlanner& plan_in_order);

}  // namespace strata::fleet_internal
