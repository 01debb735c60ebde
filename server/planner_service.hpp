#pragma once
/// strata.v1.PlannerService: runs strata::Plan for each request on a shared, read-only map.
#include <atomic>
#include <functional>
#include <optional>

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

class PlannerServiceImpl final : public v1::PlannerService::Service {
 public:
  /// `registry` and `metrics` (may be null) must outlive the service.
  PlannerServiceImpl(const MapRegistry* registry, Metrics* metrics, PlannerServiceOptions options);

  grpc::Status Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                    v1::PlanResponse* response) override;

  /// Stops every plan running or queued now and later: they answer SHUTTING_DOWN (the end of
  /// the shutdown grace). Thread-safe.
  void StopPlans() { stopping_ = true; }

 private:
  std::atomic<bool> stopping_ = false;
  const MapRegistry* registry_;
  Metrics* metrics_;
  PlannerServiceOptions options_;
  ConcurrencyLimiter slots_;
};

}  // namespace strata::server
