#include "planner_service.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

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

Result<ParsedCostRequest> ParseEstimateCostsRequest(const v1::EstimateCostsRequest& request,
                                                    int max_cells) {
  ParsedCostRequest parsed;
  if (request.map_id().empty()) {
    return MakeError(ErrorCode::kInvalidInput, "map_id is required (ListMaps shows the maps)")
        .Blame("map_id");
  }
  const std::int64_t cells =
      std::int64_t{request.starts_m_size()} * std::int64_t{request.goals_m_size()};
  if (cells > max_cells) {
    return MakeError(ErrorCode::kResourceExhausted,
                     std::to_string(request.starts_m_size()) + " starts × " +
                         std::to_string(request.goals_m_size()) + " goals make " +
                         std::to_string(cells) + " cells, more than the " +
                         std::to_string(max_cells) +
                         " one estimate may hold on this server (--max-cost-cells): split the "
                         "starts or the goals over several calls")
        .Blame(request.starts_m_size() >= request.goals_m_size() ? "starts_m" : "goals_m");
  }
  Result<RobotProfile> profile = ProfileFromRequest(request);
  if (!profile.ok()) return std::move(profile).error();
  parsed.profile = std::move(profile).value();
  parsed.inline_profile = request.has_profile();
  Result<std::vector<Prism>> keep_out = KeepOutFromRequest(request);
  if (!keep_out.ok()) return std::move(keep_out).error();
  parsed.keep_out = std::move(keep_out).value();
  PlanOptions defaults;
  parsed.snap_tolerance_m =
      request.has_snap_tolerance_m() ? request.snap_tolerance_m() : defaults.snap_tolerance_m;
  // The zones and the tolerance as a plan with them would check them (the one definition of
  // a valid zone, and of a valid tolerance, is PlanRequest::Validate's).
  PlanRequest as_plan;
  as_plan.profile = parsed.profile;
  as_plan.keep_out = parsed.keep_out;
  as_plan.options.snap_tolerance_m = parsed.snap_tolerance_m;
  if (Status valid = as_plan.Validate(); !valid) {
    const std::string& field = valid.error().field;
    return ServiceError::FromPlanner(valid.error(),
                                     field == "options.snap_tolerance_m"
                                         ? std::string("snap_tolerance_m")
                                         : PlanRequestField(field, parsed.inline_profile));
  }
  parsed.starts_m = PositionsFromProto(request.starts_m());
  parsed.goals_m = PositionsFromProto(request.goals_m());
  return parsed;
}

PlannerServiceImpl::PlannerServiceImpl(const MapRegistry* registry, Metrics* metrics,
                                       PlannerServiceOptions options)
    : registry_(registry),
      metrics_(metrics),
      options_(options),
      slots_(options.max_concurrent_plans, options.max_queued_plans) {}

ServiceStatus PlannerServiceImpl::AcquireSlot(grpc::ServerContext& context, double left_s) {
  const auto should_stop = [this, &context] { return stopping_ || context.IsCancelled(); };
  // A call waits for its slot until its own deadline (less the margin to answer); one
  // without a deadline, at most --max-plan-time-s.
  const bool has_deadline = std::isfinite(left_s);
  const auto queue_deadline =
      has_deadline
          ? QueueDeadline(left_s)
          : SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                     std::chrono::duration<double>(options_.max_plan_time_s));
  switch (slots_.Acquire(queue_deadline, should_stop)) {
    case ConcurrencyLimiter::Admission::kAdmitted: return OkStatus();
    case ConcurrencyLimiter::Admission::kStopped:
      return MakeError(ErrorCode::kCancelled, "the client cancelled the call while it was queued");
    case ConcurrencyLimiter::Admission::kQueueFull:
      return MakeError(ServiceErrorCode::kServerBusy,
                       "all " + std::to_string(slots_.slots()) + " planning slots are busy and " +
                           std::to_string(slots_.max_queued()) +
                           " calls already wait (--max-queued-plans): retry with backoff");
    case ConcurrencyLimiter::Admission::kTimedOut:
      return MakeError(
          ServiceErrorCode::kServerBusy,
          "all " + std::to_string(slots_.slots()) + " planning slots stayed busy until " +
              (has_deadline ? std::string("the call's deadline: retry with backoff, or allow "
                                          "a later deadline")
                            : "--max-plan-time-s had passed (the call set no deadline): "
                              "retry with backoff, or set a deadline"));
  }
  return MakeError(ServiceErrorCode::kInternal, "unknown admission");
}

ServiceStatus PlannerServiceImpl::ExplainStop(ServiceStatus outcome) const {
  if (!outcome.ok() && stopping_ &&
      outcome.error().code == ServiceError::Code(ErrorCode::kCancelled)) {
    return MakeError(ServiceErrorCode::kShuttingDown,
                     "the server is shutting down and its grace (--shutdown-grace-s) ran "
                     "out before the call finished: call again (another replica answers)");
  }
  return outcome;
}

ServiceStatus PlannerServiceImpl::PlanOne(grpc::ServerContext& context,
                                          const v1::PlanRequest& request,
                                          v1::PlanResponse* response, PlanTimings* timings) {
  auto outcome = [&]() -> ServiceStatus {
    Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
    if (!parsed.ok()) return std::move(parsed).error();
    Result<ActiveMap> map = registry_->GetActive(request.map_id(), request.map_version());
    if (!map.ok()) return std::move(map).error();

    const auto should_stop = [this, &context] { return stopping_ || context.IsCancelled(); };
    const double left_s = DeadlineLeftSeconds(context);
    if (left_s <= 0) return BudgetExhausted(left_s);
    const auto queue_start = SteadyClock::now();
    if (ServiceStatus admitted = AcquireSlot(context, left_s); !admitted.ok()) return admitted;
    ConcurrencyLimiter::Slot slot(&slots_);
    const double queue_s = std::chrono::duration<double>(SteadyClock::now() - queue_start).count();

    ParsedPlanRequest capped = std::move(parsed).value();
    const double budget_s =
        PlanTimeBudget(capped, DeadlineLeftSeconds(context), options_.max_plan_time_s);
    if (budget_s <= 0) return BudgetExhausted(DeadlineLeftSeconds(context));
    capped.plan.options.time_budget_s = budget_s;
    ServiceStatus status =
        PlanOnMap(*map.value().map, capped, should_stop, options_.max_samples, response, timings);
    if (!status.ok()) return status;
    response->set_map_version(map.value().version);
    response->mutable_stats()->mutable_timings()->set_queue_s(queue_s);
    return OkStatus();
  }();
  outcome = ExplainStop(std::move(outcome));
  if (!outcome.ok()) {
    ServiceError error = std::move(outcome).error();
    if (!request.map_id().empty()) error.With("map_id", request.map_id().substr(0, 64));
    if (metrics_ != nullptr) metrics_->RecordPlan(MapError(error.code).reason, nullptr);
    return error;
  }
  if (metrics_ != nullptr) metrics_->RecordPlan("OK", timings);
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
    PlanTimings timings;
    if (ServiceStatus planned = PlanOne(*context, *request, response, &timings); !planned.ok()) {
      return planned;
    }
    char ms[32];
    std::snprintf(ms, sizeof(ms), "%.1f", timings.total_s * 1e3);
    log.fields.emplace_back("plan_ms", ms);
    return OkStatus();
  });
}

grpc::Status PlannerServiceImpl::PlanBatch(grpc::ServerContext* context,
                                           const v1::PlanBatchRequest* request,
                                           grpc::ServerWriter<v1::PlanBatchResponse>* writer) {
  return RunRpc("PlanBatch", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    const int count = request->requests_size();
    if (count == 0) {
      return MakeError(ErrorCode::kInvalidInput, "requests is empty: give at least one plan")
          .Blame("requests");
    }
    if (count > options_.max_batch_plans) {
      return MakeError(ErrorCode::kResourceExhausted,
                       std::to_string(count) + " plans are more than the " +
                           std::to_string(options_.max_batch_plans) +
                           " one batch may hold on this server (--max-batch-plans): split them "
                           "over several calls")
          .Blame("requests");
    }
    log.fields.emplace_back("plans", std::to_string(count));
    // As many workers as slots, each planning one item at a time as a Plan call would (queued
    // first come first served with every other call), and writing its result as soon as it is
    // ready. Writes are serialised: a stream takes one at a time.
    std::atomic<int> next{0}, planned{0}, failed{0};
    std::atomic<bool> stream_broken{false};
    std::mutex write_mutex;
    const auto work = [&] {
      for (int i = next++; i < count && !stream_broken && !context->IsCancelled(); i = next++) {
        v1::PlanBatchResponse item;
        item.set_index(static_cast<std::uint32_t>(i));
        ServiceStatus outcome = OkStatus();
        try {
          PlanTimings timings;
          outcome = PlanOne(*context, request->requests(i), item.mutable_response(), &timings);
        } catch (...) {
          outcome = ErrorFromException(std::current_exception());
        }
        if (outcome.ok()) {
          ++planned;
        } else {
          ++failed;
          *item.mutable_error() = ToRpcStatus(outcome.error());
        }
        std::lock_guard lock(write_mutex);
        if (!writer->Write(item)) stream_broken = true;
      }
    };
    const int workers = std::min(count, slots_.slots());
    std::vector<std::thread> helpers;
    helpers.reserve(static_cast<std::size_t>(workers - 1));
    for (int w = 1; w < workers; ++w) helpers.emplace_back(work);
    work();
    for (std::thread& helper : helpers) helper.join();
    log.fields.emplace_back("planned", std::to_string(planned.load()));
    log.fields.emplace_back("failed", std::to_string(failed.load()));
    const std::string done = std::to_string(planned + failed) + " of " + std::to_string(count);
    if (DeadlineLeftSeconds(*context) <= 0) {
      return MakeError(ErrorCode::kDeadlineExceeded,
                       "the call's deadline passed after " + done +
                           " results: allow more time, or send fewer plans per batch");
    }
    if (context->IsCancelled() || stream_broken) {
      return ExplainStop(MakeError(
          ErrorCode::kCancelled,
          "the client cancelled the batch (or stopped reading it) after " + done + " results"));
    }
    return OkStatus();
  });
}

grpc::Status PlannerServiceImpl::EstimateCosts(grpc::ServerContext* context,
                                               const v1::EstimateCostsRequest* request,
                                               v1::EstimateCostsResponse* response) {
  return RunRpc("EstimateCosts", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    log.fields.emplace_back(
        "cells", std::to_string(std::int64_t{request->starts_m_size()} * request->goals_m_size()));
    ServiceStatus outcome = ExplainStop(Estimate(*context, *request, response));
    if (!outcome.ok()) {
      ServiceError error = std::move(outcome).error();
      if (!request->map_id().empty()) error.With("map_id", request->map_id().substr(0, 64));
      return error;
    }
    char ms[32];
    std::snprintf(ms, sizeof(ms), "%.1f", response->stats().total_s() * 1e3);
    log.fields.emplace_back("estimate_ms", ms);
    return OkStatus();
  });
}

ServiceStatus PlannerServiceImpl::Estimate(grpc::ServerContext& context,
                                           const v1::EstimateCostsRequest& request,
                                           v1::EstimateCostsResponse* response) {
  Result<ParsedCostRequest> parsed = ParseEstimateCostsRequest(request, options_.max_cost_cells);
  if (!parsed.ok()) return std::move(parsed).error();
  const ParsedCostRequest& costs = parsed.value();
  Result<ActiveMap> map = registry_->GetActive(request.map_id(), request.map_version());
  if (!map.ok()) return std::move(map).error();
  const PlanningMap& planning_map = *map.value().map;
  if (Status fits = CheckProfileFitsMap(costs.profile, planning_map.model().config()); !fits) {
    return ServiceError::FromPlanner(fits.error(),
                                     PlanRequestField(fits.error().field, costs.inline_profile));
  }

  const double left_s = DeadlineLeftSeconds(context);
  if (left_s <= 0) return BudgetExhausted(left_s);
  const auto queue_start = SteadyClock::now();
  if (ServiceStatus admitted = AcquireSlot(context, left_s); !admitted.ok()) return admitted;
  ConcurrencyLimiter::Slot slot(&slots_);
  const auto start = SteadyClock::now();
  response->mutable_stats()->set_queue_s(
      std::chrono::duration<double>(start - queue_start).count());

  // The estimate's budget, as a plan's: the time left (less the margin to answer), at most
  // --max-plan-time-s. One stop for every thread, remembering why it fired.
  const double left_now_s = DeadlineLeftSeconds(context);
  double budget_s = options_.max_plan_time_s;
  if (std::isfinite(left_now_s)) {
    budget_s = std::min(budget_s, left_now_s - std::min(0.1 * std::max(left_now_s, 0.0), 0.1));
  }
  if (budget_s <= 0) return BudgetExhausted(left_now_s);
  const auto deadline = start + std::chrono::duration_cast<SteadyClock::duration>(
                                    std::chrono::duration<double>(budget_s));
  std::atomic<bool> expired{false};
  const std::function<bool()> should_stop = [&] {
    if (stopping_ || context.IsCancelled()) return true;
    if (SteadyClock::now() >= deadline) expired = true;
    return expired.load();
  };
  const auto stopped = [&](const Error& error) -> ServiceStatus {
    if (!expired) return ServiceError::FromPlanner(error);
    char buf[200];
    std::snprintf(buf, sizeof(buf),
                  "the estimate's time budget of %.3f s ran out: allow more time (the call's "
                  "deadline), or ask for fewer starts and goals",
                  budget_s);
    return MakeError(ErrorCode::kDeadlineExceeded, buf);
  };

  Expected<std::shared_ptr<const SurfaceGraph>> graph =
      planning_map.Graph(costs.profile.Traversability(), should_stop);
  if (!graph) return stopped(graph.error());
  const std::vector<KeepOutZone> zones = CollectKeepOut(planning_map, costs.keep_out);
  Expected<TravelCostQuery> query =
      TravelCostQuery::Prepare(**graph, costs.profile, costs.starts_m, costs.goals_m, zones,
                               costs.snap_tolerance_m, TravelCostConfig{}, should_stop);
  if (!query) {
    if (query.error().code == ErrorCode::kCancelled) return stopped(query.error());
    return ServiceError::FromPlanner(query.error(), query.error().field);
  }
  const auto searching = SteadyClock::now();

  // The searches: on this call's slot, and on other slots while they are idle (TryAcquire
  // never takes a turn from a waiting call); a helper gives its slot back as soon as a call
  // waits for one.
  TravelCostMatrix matrix = query->InitialMatrix();
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::mutex error_mutex;
  std::optional<Error> first_error;
  const auto run = [&](bool helper) {
    TravelCostWorkspace workspace;
    for (int k = next++; k < query->search_count() && !failed; k = next++) {
      Status searched = query->RunSearch(k, &workspace, &matrix, should_stop);
      if (!searched) {
        failed = true;
        std::lock_guard lock(error_mutex);
        if (!first_error) first_error = searched.error();
        return;
      }
      if (helper && slots_.queued() > 0) return;
    }
  };
  const auto run_guarded = [&](bool helper) {
    try {
      run(helper);
    } catch (...) {
      failed = true;
      std::lock_guard lock(error_mutex);
      if (!first_error) {
        first_error = Error{ErrorCode::kResourceExhausted,
                            ErrorFromException(std::current_exception()).message};
      }
    }
  };
  std::vector<std::thread> helpers;
  for (int s = 1; s < std::min(slots_.slots(), query->search_count()) && slots_.TryAcquire(); ++s) {
    helpers.emplace_back([&] {
      ConcurrencyLimiter::Slot helper_slot(&slots_);
      run_guarded(true);
    });
  }
  run_guarded(false);
  for (std::thread& helper : helpers) helper.join();
  if (failed) {
    if (first_error->code == ErrorCode::kCancelled) return stopped(*first_error);
    return ServiceError::FromPlanner(*first_error);
  }

  ToProto(*query, matrix, response);
  ToProto(costs.profile, response->mutable_profile());
  response->set_map_version(map.value().version);
  v1::EstimateCostsStats* stats = response->mutable_stats();
  const auto end = SteadyClock::now();
  stats->set_prepare_s(std::chrono::duration<double>(searching - start).count());
  stats->set_search_s(std::chrono::duration<double>(end - searching).count());
  stats->set_total_s(std::chrono::duration<double>(end - start).count());
  stats->set_searches(query->search_count());
  stats->set_slots_used(1 + static_cast<int>(helpers.size()));
  stats->set_search_nodes(query->search_node_count());
  return OkStatus();
}

}  // namespace strata::server
