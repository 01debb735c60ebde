#pragma once
/// strata.v1.PlannerService: runs strata::Plan for each request on a shared, read-only map
/// (Plan, and many at once for PlanBatch) and travel-cost estimates (EstimateCosts), all on
/// the same planning slots.
#include <atomic>
#include <functional>
#include <optional>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "auth.hpp"
#include "concurrency_limiter.hpp"
#include "map_registry.hpp"
#include "strata/v1/planner_service.grpc.pb.h"

namespace strata::server {

class Metrics;

/// Set from ServerConfig (server/flags.hpp), which holds the defaults and the flags: no
/// default is repeated here.
struct PlannerServiceOptions {
  /// Cap on every plan's time budget [s], > 0 (--max-plan-time-s).
  double max_plan_time_s = 0;
  /// Plans run at the same time [-], >= 1 (--max-concurrent-plans, 0 resolved to the cores).
  int max_concurrent_plans = 0;
  /// Plans waiting for a slot at most [-], >= 0 (--max-queued-plans).
  int max_queued_plans = 0;
  /// Tokens the calls must carry (--auth-tokens); null lets every call through.
  const TokenTable* tokens = nullptr;
  /// Most trajectory samples one response may carry [-], >= 2 (kMaxResponseSamples).
  int max_samples = 0;
  /// Most cells (starts × goals) of one EstimateCosts call [-], >= 1 (--max-cost-cells).
  int max_cost_cells = 0;
  /// Most plans of one PlanBatch call [-], >= 1 (--max-batch-plans).
  int max_batch_plans = 0;
};

/// A request converted and validated, before any map is touched.
struct ParsedPlanRequest {
  PlanRequest plan;                   ///< options.time_budget_s not yet capped.
  bool time_budget_given = false;     ///< options.time_budget_s was set.
  bool inline_profile = false;        ///< The profile came inline (else by name).
  std::optional<double> sample_dt_s;  ///< options.sample_dt_s, when set.
};

/// Converts `request`; errors blame the field ("start.position_m.x", "profile.max_tilt_rad",
/// "options.sample_dt_s", ...).
Result<ParsedPlanRequest> ParsePlanRequest(const v1::PlanRequest& request);

/// The time budget of one plan [s]: the request's (or the planner's default), capped by the
/// server's cap and by the time left before the call's deadline (`deadline_left_s`, infinite
/// without one) less a margin to send the answer (10% of it, at most 0.1 s). May be <= 0.
double PlanTimeBudget(const ParsedPlanRequest& request, double deadline_left_s,
                      double server_cap_s);

/// Plans on `map` into `response` (everything but stats.timings.queue_s); `request`'s time
/// budget is already capped; `should_stop` reaches the search and the optimiser. Planner
/// errors come back blaming the request field at fault. No gRPC calls: tested without a
/// server.
ServiceStatus PlanOnMap(const PlanningMap& map, const ParsedPlanRequest& request,
                        const std::function<bool()>& should_stop, int max_samples,
                        v1::PlanResponse* response, PlanTimings* timings);

/// An EstimateCosts request converted and validated, before any map is touched.
struct ParsedCostRequest {
  RobotProfile profile;
  bool inline_profile = false;
  std::vector<Eigen::Vector3d> starts_m;
  std::vector<Eigen::Vector3d> goals_m;
  double snap_tolerance_m = 0;  ///< The request's, or PlanOptions' default.
  std::vector<Prism> keep_out;
};

/// Converts `request`; errors blame the field ("starts_m", "profile.max_tilt_rad",
/// "keep_out[0].z_max_m", ...). More than `max_cells` starts × goals fail with
/// RESOURCE_EXHAUSTED naming --max-cost-cells; the ends' values are checked by the planner
/// (TravelCostQuery::Prepare).
Result<ParsedCostRequest> ParseEstimateCostsRequest(const v1::EstimateCostsRequest& request,
                                                    int max_cells);

class PlannerServiceImpl final : public v1::PlannerService::Service {
 public:
  /// `registry` and `metrics` (may be null) must outlive the service.
  PlannerServiceImpl(const MapRegistry* registry, Metrics* metrics, PlannerServiceOptions options);

  grpc::Status Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                    v1::PlanResponse* response) override;
  grpc::Status EstimateCosts(grpc::ServerContext* context, const v1::EstimateCostsRequest* request,
                             v1::EstimateCostsResponse* response) override;
  grpc::Status PlanBatch(grpc::ServerContext* context, const v1::PlanBatchRequest* request,
                         grpc::ServerWriter<v1::PlanBatchResponse>* writer) override;

  /// Stops every plan running or queued now and later: they answer SHUTTING_DOWN (the end of
  /// the shutdown grace). Thread-safe.
  void StopPlans() { stopping_ = true; }

 private:
  // Waits for a planning slot, first come first served with every other caller, until the
  // call's deadline (less the margin to answer; `left_s` before it, infinite without one:
  // then at most --max-plan-time-s). On success a slot is held: release it with a Slot.
  ServiceStatus AcquireSlot(grpc::ServerContext& context, double left_s);
  // One plan as Plan makes it, from the request to the result recorded in the metrics: the
  // response, or the error Plan returns (with the map id as metadata). `timings` receives the
  // plan's stages. Shared by Plan and each item of PlanBatch.
  ServiceStatus PlanOne(grpc::ServerContext& context, const v1::PlanRequest& request,
                        v1::PlanResponse* response, PlanTimings* timings);
  // The estimate of EstimateCosts, without its metadata.
  ServiceStatus Estimate(grpc::ServerContext& context, const v1::EstimateCostsRequest& request,
                         v1::EstimateCostsResponse* response);
  // A cancellation that StopPlans caused, as SHUTTING_DOWN (the planner and the queue report
  // it as cancelled); anything else as it is.
  ServiceStatus ExplainStop(ServiceStatus outcome) const;

  std::atomic<bool> stopping_ = false;
  const MapRegistry* registry_;
  Metrics* metrics_;
  PlannerServiceOptions options_;
  ConcurrencyLimiter slots_;
};

}  // namespace strata::server
