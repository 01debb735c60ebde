#include "planner_service.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "error_mapping.hpp"
#include "metrics.hpp"
#include "proto_convert.hpp"
#include "rpc_boundary.hpp"

namespace strata::server {

Result<ParsedPlanRequest> ParsePlanRequest(const v1::PlanRequest& request) {
  ParsedPlanRequest parsed;
  if (request.map_id().empty()) {
    return MakeError(ErrorCode::kInvalidInput, "map_id is required (ListMaps shows the maps)")
        .Blame("map_id");
  }
  Result<RobotProfile> profile = ProfileFromRequest(request);
  if (!profile.ok()) return std::move(profile).error();
  parsed.plan.profile = std::move(profile).value();
  parsed.inline_profile = request.has_profile();
  if (!request.has_start()) {
    return MakeError(ErrorCode::kInvalidInput, "start is required").Blame("start");
  }
  if (!request.has_goal()) {
    return MakeError(ErrorCode::kInvalidInput, "goal is required").Blame("goal");
  }
  Result<RobotState> start = FromProto(request.start(), "start");
  if (!start.ok()) return std::move(start).error();
  Result<RobotState> goal = FromProto(request.goal(), "goal");
  if (!goal.ok()) return std::move(goal).error();
  parsed.plan.start = start.value();
  parsed.plan.goal = goal.value();
  parsed.plan.options = FromProto(request.options());
  Result<std::vector<Prism>> keep_out = KeepOutFromRequest(request);
  if (!keep_out.ok()) return std::move(keep_out).error();
  parsed.plan.keep_out = std::move(keep_out).value();
  if (request.has_warm_start()) {
    Result<WarmStart> warm = WarmStartFromRequest(request.warm_start());
    if (!warm.ok()) return std::move(warm).error();
    parsed.plan.warm_start = std::move(warm).value();
  }
  if (Status valid = parsed.plan.Validate(); !valid) {
    return ServiceError::FromPlanner(valid.error(),
                                     PlanRequestField(valid.error().field, parsed.inline_profile));
  }
  parsed.time_budget_given = request.options().has_time_budget_s();
  if (request.options().has_sample_dt_s()) {
    const double dt = request.options().sample_dt_s();
    if (!(std::isfinite(dt) && dt > 0)) {
      return MakeError(ErrorCode::kInvalidConfig, "options.sample_dt_s = " + std::to_string(dt) +
                                                      " is out of range: must be > 0 and finite")
          .Blame("options.sample_dt_s");
    }
    parsed.sample_dt_s = dt;
  }
  parsed.return_search_path = request.options().return_search_path();
  return parsed;
}

double PlanTimeBudget(const ParsedPlanRequest& request, double deadline_left_s,
                      double server_cap_s) {
  return std::min(
      {request.plan.options.time_budget_s, server_cap_s, WorkSecondsLeft(deadline_left_s)});
}

ServiceStatus PlanOnMap(const PlanningMap& map, const ParsedPlanRequest& request,
                        const std::function<bool()>& should_stop, int max_samples,
                        v1::PlanResponse* response, PlanTimings* timings) {
  Expected<PlanResult> result = strata::Plan(map, request.plan, should_stop);
  if (!result.ok()) {
    return ServiceError::FromPlanner(
        result.error(), PlanRequestField(result.error().field, request.inline_profile));
  }
  const PlanResult& plan = result.value();
  ToProto(plan.trajectory, response->mutable_trajectory());
  ToProto(plan.start, response->mutable_start());
  ToProto(plan.goal, response->mutable_goal());
  ToProto(plan.stats, response->mutable_stats());
  ToProto(request.plan.profile, response->mutable_profile());
  response->set_time_budget_s(request.plan.options.time_budget_s);
  if (request.sample_dt_s.has_value()) {
    ServiceStatus sampled =
        AppendSamples(plan.trajectory, *request.sample_dt_s, max_samples, response);
    if (!sampled.ok()) return sampled;
  }
  if (request.return_search_path) AppendSearchPath(plan.path, response);
  *timings = plan.stats.timings;
  return OkStatus();
}

PlannerServiceImpl::PlannerServiceImpl(const MapRegistry* registry, Metrics* metrics,
                                       PlannerServiceOptions options)
    : registry_(registry), metrics_(metrics), options_(options) {}

ServiceStatus PlannerServiceImpl::RunPlan(const v1::PlanRequest& request, const CallControl& call,
                                          std::string_view transport, v1::PlanResponse* response) {
  const auto start = std::chrono::steady_clock::now();
  PlanTimings timings;
  ServiceStatus outcome = [&]() -> ServiceStatus {
    Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
    if (!parsed.ok()) return std::move(parsed).error();
    Result<ActiveMap> map = registry_->GetActive(request.map_id(), request.map_version());
    if (!map.ok()) return std::move(map).error();
    PlanningSlots& slots = *options_.slots;
    return slots.Run(
        call, [&](const std::function<bool()>& should_stop, double queue_s) -> ServiceStatus {
          ParsedPlanRequest capped = std::move(parsed).value();
          const double budget_s =
              PlanTimeBudget(capped, call.LeftSeconds(), slots.max_plan_time_s());
          if (budget_s <= 0) return DeadlineLeavesNoTime(call.LeftSeconds());
          capped.plan.options.time_budget_s = budget_s;
          ServiceStatus status = PlanOnMap(*map.value().map, capped, should_stop,
                                           options_.max_samples, response, &timings);
          if (!status.ok()) return status;
          response->set_map_version(map.value().version);
          response->mutable_stats()->mutable_timings()->set_queue_s(queue_s);
          return OkStatus();
        });
  }();
  if (!outcome.ok() && !request.map_id().empty()) {
    ServiceError error = std::move(outcome).error();
    error.With("map_id", request.map_id().substr(0, 64));
    outcome = std::move(error);
  }
  if (metrics_ != nullptr) {
    metrics_->RecordPlan(
        outcome.ok() ? std::string_view("OK") : MapError(outcome.error().code).reason,
        outcome.ok() ? &timings : nullptr);
  }
  if (options_.recent_plans != nullptr) {
    v1::RecentPlan recent;
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    const auto seconds = std::chrono::floor<std::chrono::seconds>(now);
    recent.mutable_time()->set_seconds(seconds.count());
    recent.mutable_time()->set_nanos(static_cast<int>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(now - seconds).count()));
    recent.set_duration_s(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    *recent.mutable_request() = request;
    if (outcome.ok()) {
      *recent.mutable_response() = *response;
      recent.mutable_response()->clear_samples();  // The trajectory holds them.
    } else {
      ToProto(outcome.error(), recent.mutable_error());
    }
    recent.set_transport(std::string(transport));
    options_.recent_plans->Record(std::move(recent));
  }
  return outcome;
}

ServiceStatus PlannerServiceImpl::ListRecentPlans(const v1::ListRecentPlansRequest& request,
                                                  v1::ListRecentPlansResponse* response) const {
  if (request.max_plans() < 0) {
    return MakeError(ErrorCode::kInvalidInput,
                     "max_plans = " + std::to_string(request.max_plans()) +
                         " is out of range: must be >= 0 (0 returns every plan kept)")
        .Blame("max_plans");
  }
  if (options_.recent_plans != nullptr) {
    options_.recent_plans->List(static_cast<std::size_t>(request.max_plans()), response);
  }
  return OkStatus();
}

grpc::Status PlannerServiceImpl::Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                                      v1::PlanResponse* response) {
  return RunRpc("Plan", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    ServiceStatus status = RunPlan(*request, CallControlOf(*context), "grpc", response);
    if (!status.ok()) return status;
    char ms[32];
    std::snprintf(ms, sizeof(ms), "%.1f", response->stats().timings().total_s() * 1e3);
    log.fields.emplace_back("plan_ms", ms);
    return OkStatus();
  });
}

grpc::Status PlannerServiceImpl::ListRecentPlans(grpc::ServerContext* context,
                                                 const v1::ListRecentPlansRequest* request,
                                                 v1::ListRecentPlansResponse* response) {
  return RunRpc("ListRecentPlans", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.quiet_on_success = true;
    return ListRecentPlans(*request, response);
  });
}

}  // namespace strata::server
