#include "rpc/planner_service.hpp"

#include "common/map_id.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "rpc/error_mapping.hpp"
#include "rpc/fleet_planning.hpp"
#include "rpc/metrics.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/rpc_boundary.hpp"
#include "rpc/traffic_convert.hpp"

namespace strata::server {

namespace {

Result<ParsedFleet> ParseFleet(const v1::PlanRequest& request) {
  const v1::FleetOptions& fleet = request.fleet();
  ParsedFleet parsed;
  parsed.robot_id = fleet.robot_id();
  parsed.avoid_reservations = !fleet.has_avoid_reservations() || fleet.avoid_reservations();
  parsed.reserve = fleet.reserve();
  if (fleet.has_lease_s()) parsed.lease_s = fleet.lease_s();
  if (fleet.has_separation_m()) parsed.separation_m = fleet.separation_m();
  if (fleet.has_max_wait_s()) parsed.options.max_wait_s = fleet.max_wait_s();
  parsed.follows_replans = fleet.follows_replans();
  if (fleet.replan_robots() > static_cast<std::uint32_t>(kMaxReplannedRobots)) {
    return MakeError(ErrorCode::kInvalidConfig,
                     fmt::format("fleet.replan_robots = {} is out of range: at most {} robots may "
                                 "be replanned for one plan",
                                 fleet.replan_robots(), kMaxReplannedRobots))
        .Blame("fleet.replan_robots");
  }
  parsed.options.replan.max_robots = static_cast<int>(fleet.replan_robots());
  for (const auto& [given, name] : {std::pair{parsed.follows_replans, "fleet.follows_replans"},
                                    std::pair{fleet.replan_robots() > 0, "fleet.replan_robots"}}) {
    if (given && !parsed.reserve) {
      return MakeError(ErrorCode::kInvalidInput,
                       fmt::format("{} is set without fleet.reserve: it applies to the "
                                   "reservation the plan commits; set fleet.reserve too",
                                   name))
          .Blame(name);
    }
  }
  if (Status valid = parsed.options.Validate("fleet"); !valid) {
    return ServiceError::FromPlanner(valid.error(), valid.error().field);
  }
  if (request.has_departure_time()) {
    Result<std::int64_t> departure = FromProto(request.departure_time(), "departure_time");
    if (!departure.ok()) return std::move(departure).error();
    parsed.departure_ns = departure.value();
  }
  return parsed;
}

}  // namespace

Result<ParsedPlanRequest> ParsePlanRequest(const v1::PlanRequest& request) {
  ParsedPlanRequest parsed;
  if (ServiceStatus given = RequireMapId(request.map_id()); !given.ok()) {
    return std::move(given).error();
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
  Result<std::vector<Via>> via = ViasFromRequest(request);
  if (!via.ok()) return std::move(via).error();
  parsed.plan.via = std::move(via).value();
  if (Status valid = parsed.plan.Validate(); !valid) {
    return ServiceError::FromPlanner(valid.error(),
                                     PlanRequestField(valid.error().field, parsed.inline_profile));
  }
  parsed.time_budget_given = request.options().has_time_budget_s();
  if (request.options().has_sample_dt_s()) {
    const double dt = request.options().sample_dt_s();
    if (!(std::isfinite(dt) && dt > 0)) {
      return MakeError(ErrorCode::kInvalidConfig,
                       fmt::format("options.sample_dt_s = {:f} is out of range: must be > 0 and "
                                   "finite",
                                   dt))
          .Blame("options.sample_dt_s");
    }
    parsed.sample_dt_s = dt;
  }
  parsed.return_search_path = request.options().return_search_path();
  if (request.has_fleet()) {
    Result<ParsedFleet> fleet = ParseFleet(request);
    if (!fleet.ok()) return std::move(fleet).error();
    parsed.fleet = std::move(fleet).value();
  } else if (request.has_departure_time()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "departure_time is for plans among other robots: set fleet too")
        .Blame("departure_time");
  }
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
  *timings = result.value().stats.timings;
  return WritePlan(result.value(), request, max_samples, response);
}

ServiceStatus WritePlan(const PlanResult& plan, const ParsedPlanRequest& request, int max_samples,
                        v1::PlanResponse* response) {
  ToProto(plan.trajectory, response->mutable_trajectory());
  const double reference_height_m = request.plan.profile.reference_height_m;
  ToProto(plan.start, reference_height_m, response->mutable_start());
  ToProto(plan.goal, reference_height_m, response->mutable_goal());
  ToProto(plan.stats, response->mutable_stats());
  ToProto(request.plan.profile, response->mutable_profile());
  response->set_time_budget_s(request.plan.options.time_budget_s);
  response->mutable_via_times_s()->Assign(plan.via_times_s.begin(), plan.via_times_s.end());
  if (request.sample_dt_s.has_value()) {
    ServiceStatus sampled =
        AppendSamples(plan.trajectory, *request.sample_dt_s, max_samples, response);
    if (!sampled.ok()) return sampled;
  }
  if (request.return_search_path) AppendSearchPath(plan.path, response);
  return OkStatus();
}

Result<ParsedCostRequest> ParseEstimateCostsRequest(const v1::EstimateCostsRequest& request,
                                                    int max_cells) {
  ParsedCostRequest parsed;
  if (ServiceStatus given = RequireMapId(request.map_id()); !given.ok()) {
    return std::move(given).error();
  }
  const std::int64_t cells =
      std::int64_t{request.starts_m_size()} * std::int64_t{request.goals_m_size()};
  if (cells > max_cells) {
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("{} starts × {} goals make {} cells, more than the {} one "
                                 "estimate may hold on this server (--max-cost-cells): split the "
                                 "starts or the goals over several calls",
                                 request.starts_m_size(), request.goals_m_size(), cells, max_cells))
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
    : registry_(registry), metrics_(metrics), options_(options) {}

ServiceStatus PlannerServiceImpl::PlanOne(const v1::PlanRequest& request, const CallControl& call,
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
          ServiceStatus status = OkStatus();
          if (!capped.fleet.has_value()) {
            status = PlanOnMap(*map.value().map, capped, should_stop, options_.max_samples,
                               response, &timings);
          } else if (options_.reservations == nullptr) {
            status = MakeError(ErrorCode::kInvalidInput,
                               "this server keeps no reservations: plan without fleet")
                         .Blame("fleet");
          } else {
            status =
                PlanAmongReservations(map.value(), request.map_id(), capped, *options_.reservations,
                                      CallerOf(options_.tokens, call.authorization), should_stop,
                                      options_.max_samples, response, &timings);
          }
          registry_->FitHeldMaps();  // This map, which the plan may have grown, stays.
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
                     fmt::format("max_plans = {} is out of range: must be >= 0 (0 returns every "
                                 "plan kept)",
                                 request.max_plans()))
        .Blame("max_plans");
  }
  if (options_.recent_plans != nullptr) {
    options_.recent_plans->List(static_cast<std::size_t>(request.max_plans()), response);
  }
  return OkStatus();
}

grpc::Status PlannerServiceImpl::Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                                      v1::PlanResponse* response) {
  return RunRpc(Rpc(), "Plan", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    ServiceStatus status = PlanOne(*request, CallControlOf(*context), "grpc", response);
    if (!status.ok()) return status;
    log.fields.emplace_back("plan_ms",
                            fmt::format("{:.1f}", response->stats().timings().total_s() * 1e3));
    return OkStatus();
  });
}

grpc::Status PlannerServiceImpl::ListRecentPlans(grpc::ServerContext* context,
                                                 const v1::ListRecentPlansRequest* request,
                                                 v1::ListRecentPlansResponse* response) {
  return RunRpc(Rpc(), "ListRecentPlans", *context, [&](CallLog& log) -> ServiceStatus {
    log.quiet_on_success = true;
    return ListRecentPlans(*request, response);
  });
}

grpc::Status PlannerServiceImpl::PlanBatch(grpc::ServerContext* context,
                                           const v1::PlanBatchRequest* request,
                                           grpc::ServerWriter<v1::PlanBatchResponse>* writer) {
  return RunRpc(Rpc(), "PlanBatch", *context, [&](CallLog& log) -> ServiceStatus {
    const int count = request->requests_size();
    if (count == 0) {
      return MakeError(ErrorCode::kInvalidInput, "requests is empty: give at least one plan")
          .Blame("requests");
    }
    if (count > options_.max_batch_plans) {
      return MakeError(ErrorCode::kResourceExhausted,
                       fmt::format("{} plans are more than the {} one batch may hold on this "
                                   "server (--max-batch-plans): split them over several calls",
                                   count, options_.max_batch_plans))
          .Blame("requests");
    }
    log.fields.emplace_back("plans", std::to_string(count));
    const CallControl call = CallControlOf(*context);
    const auto cancelled = [&call] { return call.cancelled && call.cancelled(); };
    // As many workers as slots, each planning one item at a time as a Plan call would (PlanOne:
    // queued first come first served with every other call), and writing its result as soon
    // as it is ready. Writes are serialised: a stream takes one at a time.
    std::atomic<int> next{0}, planned{0}, failed{0};
    std::atomic<bool> stream_broken{false};
    std::mutex write_mutex;
    const auto work = [&] {
      for (int i = next++; i < count && !stream_broken && !cancelled(); i = next++) {
        v1::PlanBatchResponse item;
        item.set_index(static_cast<std::uint32_t>(i));
        ServiceStatus outcome = OkStatus();
        try {
          outcome = PlanOne(request->requests(i), call, "grpc", item.mutable_response());
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
    const int workers = std::min(count, options_.slots->slots());
    std::vector<std::thread> helpers;
    helpers.reserve(static_cast<std::size_t>(workers - 1));
    for (int w = 1; w < workers; ++w) helpers.emplace_back(work);
    work();
    for (std::thread& helper : helpers) helper.join();
    log.fields.emplace_back("planned", std::to_string(planned.load()));
    log.fields.emplace_back("failed", std::to_string(failed.load()));
    const std::string done = fmt::format("{} of {}", planned + failed, count);
    if (call.LeftSeconds() <= 0 || (cancelled() && call.LeftSeconds() <= kClientDeadlineLeadS)) {
      return MakeError(ErrorCode::kDeadlineExceeded,
                       "the call's deadline passed after " + done +
                           " results: allow more time, or send fewer plans per batch");
    }
    if (cancelled() || stream_broken) {
      return options_.slots->ExplainStop(MakeError(
          ErrorCode::kCancelled,
          "the client cancelled the batch (or stopped reading it) after " + done + " results"));
    }
    return OkStatus();
  });
}

grpc::Status PlannerServiceImpl::EstimateCosts(grpc::ServerContext* context,
                                               const v1::EstimateCostsRequest* request,
                                               v1::EstimateCostsResponse* response) {
  return RunRpc(Rpc(), "EstimateCosts", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.fields.emplace_back(
        "cells", std::to_string(std::int64_t{request->starts_m_size()} * request->goals_m_size()));
    ServiceStatus outcome = Estimate(*request, CallControlOf(*context), response);
    if (!outcome.ok()) {
      ServiceError error = std::move(outcome).error();
      if (!request->map_id().empty()) error.With("map_id", request->map_id().substr(0, 64));
      return error;
    }
    log.fields.emplace_back("estimate_ms",
                            fmt::format("{:.1f}", response->stats().total_s() * 1e3));
    return OkStatus();
  });
}

ServiceStatus PlannerServiceImpl::Estimate(const v1::EstimateCostsRequest& request,
                                           const CallControl& call,
                                           v1::EstimateCostsResponse* response) {
  Result<ParsedCostRequest> parsed = ParseEstimateCostsRequest(request, options_.max_cost_cells);
  if (!parsed.ok()) return std::move(parsed).error();
  const ParsedCostRequest& costs = parsed.value();
  Result<ActiveMap> map = registry_->GetActive(request.map_id(), request.map_version());
  if (!map.ok()) return std::move(map).error();
  if (Status fits = CheckProfileFitsMap(costs.profile, map.value().map->model().config()); !fits) {
    return ServiceError::FromPlanner(fits.error(),
                                     PlanRequestField(fits.error().field, costs.inline_profile));
  }
  ServiceStatus estimated = options_.slots->Run(
      call, [&](const std::function<bool()>& slot_stop, double queue_s) -> ServiceStatus {
        return EstimateInSlot(costs, map.value(), call, slot_stop, queue_s, response);
      });
  registry_->FitHeldMaps();  // As after a plan: the estimate may have grown this map's graphs.
  return estimated;
}

ServiceStatus PlannerServiceImpl::EstimateInSlot(const ParsedCostRequest& costs,
                                                 const ActiveMap& map, const CallControl& call,
                                                 const std::function<bool()>& slot_stop,
                                                 double queue_s,
                                                 v1::EstimateCostsResponse* response) {
  using SteadyClock = std::chrono::steady_clock;
  PlanningSlots& slots = *options_.slots;
  const auto start = SteadyClock::now();
  response->mutable_stats()->set_queue_s(queue_s);
  // The estimate's budget, as a plan's: the time left (less the margin to answer), at most
  // --max-plan-time-s. One stop for every thread, remembering why it fired.
  const double budget_s = std::min(slots.max_plan_time_s(), WorkSecondsLeft(call.LeftSeconds()));
  if (budget_s <= 0) return DeadlineLeavesNoTime(call.LeftSeconds());
  const auto deadline = start + std::chrono::duration_cast<SteadyClock::duration>(
                                    std::chrono::duration<double>(budget_s));
  std::atomic<bool> expired{false};
  const std::function<bool()> should_stop = [&] {
    if (slot_stop()) return true;
    if (SteadyClock::now() >= deadline) expired = true;
    return expired.load();
  };
  // Stopped by the client or by shutdown stays kCancelled (PlanningSlots::Run tells shutdown
  // apart); stopped by the budget is kDeadlineExceeded.
  const auto stopped = [&](const Error& error) -> ServiceStatus {
    if (!expired) return ServiceError::FromPlanner(error);
    return MakeError(ErrorCode::kDeadlineExceeded,
                     fmt::format("the estimate's time budget of {:.3f} s ran out: allow more "
                                 "time (the call's deadline), or ask for fewer starts and goals",
                                 budget_s));
  };

  const PlanningMap& planning_map = *map.map;
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

  // The searches: on this call's slot, and on idle slots borrowed besides (never a turn owed
  // to a waiting call); a helper gives its slot back as soon as a call waits for one.
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
      if (helper && slots.CallsWaiting()) return;
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
  for (int s = 1; s < std::min(slots.slots(), query->search_count()) && slots.TryBorrow(); ++s) {
    helpers.emplace_back([&] {
      PlanningSlots::BorrowedSlot borrowed(&slots);
      run_guarded(true);
    });
  }
  run_guarded(false);
  for (std::thread& helper : helpers) helper.join();
  if (failed) {
    if (first_error->code == ErrorCode::kCancelled) return stopped(*first_error);
    return ServiceError::FromPlanner(*first_error);
  }

  ToProto(*query, matrix, costs.profile.reference_height_m, response);
  ToProto(costs.profile, response->mutable_profile());
  response->set_map_version(map.version);
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
