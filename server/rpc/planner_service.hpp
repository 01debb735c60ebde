#pragma once
/// strata.v1.PlannerService: runs strata::Plan for each request on a shared, read-only map
/// (Plan, many at once for PlanBatch, and the web viewer's JSON API) and travel-cost
/// estimates (EstimateCosts), all on the same planning slots.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "maps/map_registry.hpp"
#include "rpc/auth.hpp"
#include "rpc/planning_slots.hpp"
#include "rpc/recent_plans.hpp"
#include "rpc/rpc_boundary.hpp"
#include "strata/fleet/fleet_plan.hpp"
#include "strata/v1/planner_service.grpc.pb.h"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

class Metrics;

/// Set from ServerConfig (server/ops/flags.hpp), which holds the defaults and the flags: no
/// default is repeated here.
struct PlannerServiceOptions {
  /// The planning slots every plan and estimate takes (--max-concurrent-plans,
  /// --max-queued-plans, --max-plan-time-s); shared with MapService's GetMapGeometry.
  /// Required.
  PlanningSlots* slots = nullptr;
  /// Where answered plans are kept for ListRecentPlans; null keeps none.
  RecentPlans* recent_plans = nullptr;
  /// Tokens the calls must carry (--auth-tokens); null lets every call through.
  const TokenTable* tokens = nullptr;
  /// Most trajectory samples one response may carry [-], >= 2 (kMaxResponseSamples).
  int max_samples = 0;
  /// Most cells (starts × goals) of one EstimateCosts call [-], >= 1 (--max-cost-cells).
  int max_cost_cells = 0;
  /// Most plans of one PlanBatch call [-], >= 1 (--max-batch-plans).
  int max_batch_plans = 0;
  /// The robots' reservations, which plans with a fleet block plan among and commit to;
  /// null refuses such plans.
  ReservationSchedule* reservations = nullptr;
};

/// PlanRequest.fleet and departure_time, converted (defaults the server's are applied when
/// planning: they live in ScheduleLimits).
struct ParsedFleet {
  std::string robot_id;
  bool avoid_reservations = true;
  bool reserve = false;
  std::optional<double> lease_s;
  std::optional<double> separation_m;
  bool follows_replans = false;  ///< The reservation follows replans.
  /// max_wait_s and replan.max_robots (replan_robots); the rule is set when planning.
  FleetPlanOptions options;
  std::optional<std::int64_t> departure_ns;  ///< Unset: now.
};

/// A request converted and validated, before any map is touched.
struct ParsedPlanRequest {
  PlanRequest plan;                   ///< options.time_budget_s not yet capped.
  bool time_budget_given = false;     ///< options.time_budget_s was set.
  bool inline_profile = false;        ///< The profile came inline (else by name).
  std::optional<double> sample_dt_s;  ///< options.sample_dt_s, when set.
  bool return_search_path = false;    ///< options.return_search_path.
  std::optional<ParsedFleet> fleet;   ///< When the request has a fleet block.
};

/// Converts `request`; errors blame the field ("start.position_m.x", "profile.max_tilt_rad",
/// "options.sample_dt_s", ...).
Result<ParsedPlanRequest> ParsePlanRequest(const v1::PlanRequest& request);

/// The time budget of one plan [s]: the request's (or the planner's default), capped by the
/// server's cap and by the time left before the call's deadline (`deadline_left_s`, infinite
/// without one) less a margin to send the answer (WorkSecondsLeft). May be <= 0.
double PlanTimeBudget(const ParsedPlanRequest& request, double deadline_left_s,
                      double server_cap_s);

/// Plans on `map` into `response` (everything but stats.timings.queue_s); `request`'s time
/// budget is already capped; `should_stop` reaches the search and the optimiser. Planner
/// errors come back blaming the request field at fault. No gRPC calls: tested without a
/// server.
ServiceStatus PlanOnMap(const PlanningMap& map, const ParsedPlanRequest& request,
                        const std::function<bool()>& should_stop, int max_samples,
                        v1::PlanResponse* response, PlanTimings* timings);

/// Writes `plan`, made for `request`, into `response` (everything but stats.timings.queue_s
/// and the map version); kResourceExhausted when its samples would exceed `max_samples`.
ServiceStatus WritePlan(const PlanResult& plan, const ParsedPlanRequest& request, int max_samples,
                        v1::PlanResponse* response);

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

  /// One plan, whichever way it came (`transport`: "grpc" for Plan and each item of PlanBatch,
  /// "http" for the web viewer's JSON API): parses the request, waits for a planning slot
  /// (PlanningSlots::Run, first come first served with every other call) and plans; the
  /// error is the one Plan returns (with the map id as metadata). Counts the plan in the
  /// metrics and keeps it among the recent plans. The caller has authorised the call.
  ServiceStatus PlanOne(const v1::PlanRequest& request, const CallControl& call,
                        std::string_view transport, v1::PlanResponse* response);
  /// ListRecentPlans' work; kInvalidInput blaming "max_plans" when it is negative.
  ServiceStatus ListRecentPlans(const v1::ListRecentPlansRequest& request,
                                v1::ListRecentPlansResponse* response) const;

  grpc::Status Plan(grpc::ServerContext* context, const v1::PlanRequest* request,
                    v1::PlanResponse* response) override;
  grpc::Status EstimateCosts(grpc::ServerContext* context, const v1::EstimateCostsRequest* request,
                             v1::EstimateCostsResponse* response) override;
  grpc::Status PlanBatch(grpc::ServerContext* context, const v1::PlanBatchRequest* request,
                         grpc::ServerWriter<v1::PlanBatchResponse>* writer) override;
  grpc::Status ListRecentPlans(grpc::ServerContext* context,
                               const v1::ListRecentPlansRequest* request,
                               v1::ListRecentPlansResponse* response) override;

 private:
  // The estimate of EstimateCosts, without its metadata: one planning slot taken as a plan
  // takes it, and idle ones borrowed (PlanningSlots::TryBorrow) for more searches.
  ServiceStatus Estimate(const v1::EstimateCostsRequest& request, const CallControl& call,
                         v1::EstimateCostsResponse* response);
  // The estimate once the call holds its slot (PlanningSlots::Run's `slot_stop` and
  // `queue_s`), within its own budget.
  ServiceStatus EstimateInSlot(const ParsedCostRequest& costs, const ActiveMap& map,
                               const CallControl& call, const std::function<bool()>& slot_stop,
                               double queue_s, v1::EstimateCostsResponse* response);

  const MapRegistry* registry_;
  Metrics* metrics_;
  // The service and its tokens, for the RPC boundary.
  RpcService Rpc() const { return {v1::PlannerService::service_full_name(), options_.tokens}; }

  PlannerServiceOptions options_;
};

}  // namespace strata::server
