#pragma once
// The strata subcommands. Each takes the arguments after its name (global flags already
// taken), throws UsageError for bad ones, and returns the process exit code.
#include "arguments.hpp"
#include "context.hpp"
#include "strata/v1/planner_service.pb.h"

namespace strata::cli {

/// `strata maps create|upload|get|list|delete ...`
int RunMaps(const Context& ctx, Arguments& args);
/// `strata plan ...`
int RunPlan(const Context& ctx, Arguments& args);
/// `strata setpoints ...`
int RunSetpoints(const Context& ctx, Arguments& args);

/// A PlanRequest from --map, --start, --goal, --robot, --time-budget, --sample-dt; throws
/// UsageError when one is missing or malformed.
v1::PlanRequest PlanRequestFromArguments(Arguments& args);
/// Calls Plan with the context's deadline; on failure reports it and returns false.
bool CallPlan(const Context& ctx, const v1::PlanRequest& request, v1::PlanResponse* response);

/// The usage text.
const char* UsageText();

}  // namespace strata::cli
