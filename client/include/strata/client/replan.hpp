#pragma once
/// Replanning on the way: the PlanRequest a robot sends when it replans while following a
/// trajectory. The new start is where the followed trajectory puts the robot at its time on
/// it (position, velocity, acceleration, so the new trajectory joins the old one smoothly),
/// and the followed trajectory goes along as the warm start, from whose remainder the
/// optimiser starts (proto/README.md, "Replanning on the way").
#include "strata/client/expected.hpp"
#include "strata/v1/planner_service.pb.h"

namespace strata::client {

/// `request` (map, robot, goal, options, keep-out zones as the robot wants them now) with its
/// start set to the state of `followed` (a PlanResponse the robot is executing) at `elapsed_s`
/// seconds into it, clamped to [0, its duration], and `followed`'s trajectory as the warm
/// start at that time. Fails naming the field when `followed` has no valid trajectory or
/// `elapsed_s` is not finite.
Expected<v1::PlanRequest> MakeReplanRequest(const v1::PlanRequest& request,
                                            const v1::PlanResponse& followed, double elapsed_s);

}  // namespace strata::client
