#pragma once
// The strata commands. Each Add*Command adds its subcommand(s) and their flags to the CLI11
// app; parsing sets *run to the selected one, which throws UsageError for bad input that
// parsing cannot see (a file, a combination of flags) and returns the process exit code.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "arguments.hpp"
#include "context.hpp"
#include "strata/v1/planner_service.pb.h"

namespace strata::cli {

/// The whole command line: global flags (into *ctx), every command, help.
void AddStrataCommands(CLI::App& app, Context* ctx, Command* run);

/// `strata maps create|upload|get|list|delete ...`
void AddMapsCommands(CLI::App& app, const Context& ctx, Command* run);
/// `strata plan ...`
void AddPlanCommand(CLI::App& app, const Context& ctx, Command* run);
/// `strata setpoints ...`
void AddSetpointsCommand(CLI::App& app, const Context& ctx, Command* run);
/// `strata costs ...`
void AddCostsCommand(CLI::App& app, const Context& ctx, Command* run);
/// `strata batch FILE`
void AddBatchCommand(CLI::App& app, const Context& ctx, Command* run);
/// `strata reservations list|renew|release ...`
void AddReservationsCommands(CLI::App& app, const Context& ctx, Command* run);

/// The robot profile of a request that names none, for every command that sends one (`plan`,
/// `setpoints`, `costs`, `batch`).
inline constexpr const char* kDefaultRobot = "differential";

/// The flags of a plan request, shared by `plan` and `setpoints`.
struct PlanFlags {
  std::string map;
  std::optional<std::array<double, 3>> start;
  std::optional<std::array<double, 3>> goal;
  std::string robot = kDefaultRobot;
  std::optional<double> time_budget_s;
  std::optional<double> sample_dt_s;
  std::vector<ViaPoint> via;  ///< --via, in the order given.
  std::string robot_id;       ///< --robot-id: plan among the other robots' reservations.
  bool reserve = false;       ///< --reserve: commit the plan as the robot's reservation.
  std::optional<double> lease_s;
  std::optional<double> max_wait_s;
  std::optional<double> separation_m;  ///< --separation (fleet.separation_m).
  bool follows_replans = false;        ///< --follows-replans (fleet.follows_replans).
  unsigned replan_robots = 0;          ///< --replan-robots (fleet.replan_robots).
};
/// Adds --map, --start, --goal (`required` or not), --robot, --time-budget, --sample-dt,
/// --via, --robot-id, --reserve, --lease, --max-wait, --separation, --follows-replans,
/// --replan-robots; returns them.
std::vector<CLI::Option*> AddPlanFlags(CLI::App& command, PlanFlags* flags, bool required);
/// The PlanRequest; throws UsageError when --map, --start or --goal is missing, or a fleet
/// flag (--reserve, --lease, --max-wait, --separation, --follows-replans, --replan-robots)
/// comes without --robot-id.
v1::PlanRequest PlanRequestFromFlags(const PlanFlags& flags);
/// Calls Plan with the context's deadline; on failure reports it and returns false.
bool CallPlan(const Context& ctx, const v1::PlanRequest& request, v1::PlanResponse* response);

}  // namespace strata::cli
