#include "planner_service.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "error_mapping.hpp"
#include "metrics.hpp"
#include "proto_convert.hpp"
#include "rpc_boundary.hpp"

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

double DeadlineLeftSeconds(const grpc::ServerContext& context) {
  const auto deadline = context.deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) {
    return std::numeric_limits<double>::infinity();
  }
  return std::chrono::duration<double>(deadline - std::chrono::system_clock::now()).count();
}

// When a queued plan stops waiting for a slot: before the deadline, leaving the margin
// PlanTimeBudget leaves.
SteadyClock::time_point QueueDeadline(double deadline_left_s) {
  if (!std::isfinite(deadline_left_s)) return SteadyClock::time_point::max();
  const double margin = std::min(0.1 * std::max(deadline_left_s, 0.0), 0.1);
  return SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                  std::chrono::duration<double>(deadline_left_s - margin));
}

ServiceError BudgetExhausted(double deadline_left_s) {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "the call's deadline leaves %.3f s, too little to plan: allow more time (set "
                "a later deadline)",
                std::max(0.0, deadline_left_s));
  return MakeError(ErrorCode::kDeadlineExceeded, buf);
}

}  // namespace

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
  return parsed;
}

double PlanTimeBudget(const ParsedPlanRequest& request, double deadline_left_s,
                      double server_cap_s) {
  double budget = std::min(request.plan.options.time_budget_s, server_cap_s);
  if (std::isfinite(deadline_left_s)) {
    const double margin = std::min(0.1 * std::max(deadline_left_s, 0.0), 0.1);
    budget = std::min(budget, deadline_left_s - margin);
  }
  return budget;
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
  *timings = plan.stats.timings;
  return OkStatus();
}

PlannerServiceImpl::PlannerServiceImpl(const MapRegistry* registry, Metrics* metrics,
                                       PlannerServiceOptions options)
    : registry_(registry),
      metrics_(metrics),
      options_(options),
      slots_(options.max_concurrent_plans, options.max_queued_plans) {}

grpc::Status PlannerServiceImpl::Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                                      v1::PlanResponse* response) {
  return RunRpc("Plan", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    PlanTimings timings;
    auto outcome = [&]() -> ServiceStatus {
      Result<ParsedPlanRequest> parsed = ParsePlanRequest(*request);
      if (!parsed.ok()) return std::move(parsed).error();
      Result<ActiveMap> map = registry_->GetActive(request->map_id(), request->map_version());
      if (!map.ok()) return std::move(map).error();

      const auto should_stop = [this, context] { return stopping_ || context->IsCancelled(); };
      const double left_s = DeadlineLeftSeconds(*context);
      if (left_s <= 0) return BudgetExhausted(left_s);
      const auto queue_start = SteadyClock::now();
      // A call waits for its slot until its own deadline (less the margin to answer); one
      // without a deadline, at most --max-plan-time-s.
      const bool has_deadline = std::isfinite(left_s);
      const auto queue_deadline =
          has_deadline ? QueueDeadline(left_s)
                       : queue_start + std::chrono::duration_cast<SteadyClock::duration>(
                                           std::chrono::duration<double>(options_.max_plan_time_s));
      switch (slots_.Acquire(queue_deadline, should_stop)) {
        case ConcurrencyLimiter::Admission::kAdmitted: break;
        case ConcurrencyLimiter::Admission::kStopped:
          return MakeError(ErrorCode::kCancelled, "the client cancelled the plan while queued");
        case ConcurrencyLimiter::Admission::kQueueFull:
          return MakeError(ServiceErrorCode::kServerBusy,
                           "all " + std::to_string(slots_.slots()) +
                               " planning slots are busy and " +
                               std::to_string(slots_.max_queued()) +
                               " plans already wait (--max-queued-plans): retry with backoff");
        case ConcurrencyLimiter::Admission::kTimedOut:
          return MakeError(
              ServiceErrorCode::kServerBusy,
              "all " + std::to_string(slots_.slots()) + " planning slots stayed busy until " +
                  (has_deadline ? std::string("the call's deadline: retry with backoff, or allow "
                                              "a later deadline")
                                : "--max-plan-time-s had passed (the call set no deadline): "
                                  "retry with backoff, or set a deadline"));
      }
      ConcurrencyLimiter::Slot slot(&slots_);
      const double queue_s =
          std::chrono::duration<double>(SteadyClock::now() - queue_start).count();

      ParsedPlanRequest capped = std::move(parsed).value();
      const double budget_s =
          PlanTimeBudget(capped, DeadlineLeftSeconds(*context), options_.max_plan_time_s);
      if (budget_s <= 0) return BudgetExhausted(DeadlineLeftSeconds(*context));
      capped.plan.options.time_budget_s = budget_s;
      ServiceStatus status = PlanOnMap(*map.value().map, capped, should_stop, options_.max_samples,
                                       response, &timings);
      if (!status.ok()) return status;
      response->set_map_version(map.value().version);
      response->mutable_stats()->mutable_timings()->set_queue_s(queue_s);
      return OkStatus();
    }();
    // A plan stopped by StopPlans (the planner and the queue report it as cancelled) says why.
    if (!outcome.ok() && stopping_ &&
        outcome.error().code == ServiceError::Code(ErrorCode::kCancelled)) {
      outcome = MakeError(ServiceErrorCode::kShuttingDown,
                          "the server is shutting down and its grace (--shutdown-grace-s) ran "
                          "out before the plan finished: plan again (another replica answers)");
    }
    if (!outcome.ok()) {
      ServiceError error = std::move(outcome).error();
      if (!request->map_id().empty()) error.With("map_id", request->map_id().substr(0, 64));
      if (metrics_ != nullptr) metrics_->RecordPlan(MapError(error.code).reason, nullptr);
      return error;
    }
    if (metrics_ != nullptr) metrics_->RecordPlan("OK", &timings);
    char ms[32];
    std::snprintf(ms, sizeof(ms), "%.1f", timings.total_s * 1e3);
    log.fields.emplace_back("plan_ms", ms);
    return OkStatus();
  });
}

}  // namespace strata::server
