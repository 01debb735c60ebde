#pragma once
/// Prometheus metrics, collected with prometheus-cpp and served at /metrics by
/// http/metrics_page.hpp.
///
/// gRPC metrics with go-grpc-prometheus's names and labels (grpc_type, grpc_service,
/// grpc_method; grpc_code spelled as Go spells codes, e.g. "NotFound"), recorded for every
/// call by a server interceptor:
///   grpc_server_started_total, grpc_server_handled_total{grpc_code},
///   grpc_server_msg_received_total, grpc_server_msg_sent_total,
///   grpc_server_handling_seconds (histogram).
/// Strata metrics:
///   strata_plans_total{result}                 result "OK" or the error reason
///   strata_plan_duration_seconds{stage}        graph, snap, search, optimize, verify, total
///   strata_map_assessment_seconds{stage}       load, ground_filter, surfaces, fields, total
///   strata_maps{state}                         creating, active, failed (read at scrape)
///   strata_map_memory_bytes                    sum over ACTIVE maps (read at scrape)
///   strata_memory_budget_bytes                 --max-memory (read at scrape)
///   strata_memory_reserved_bytes{use}          uploads, assessments (read at scrape)
///   strata_map_creation_progress_ratio{map_id,step}  per CREATING map, in [0, 1] (at scrape)
///   strata_reservations                        robots' live reservations, all maps (at scrape)
///   strata_reservations_expired_total          expired leases collected (read at scrape)
///   strata_reservations_replanned_total        reservations replanned for other plans (at scrape)
///   strata_plans_queued                        calls waiting for a planning slot (at scrape):
///                                              the figure an autoscaler scales on
///   strata_planning_slots_busy, strata_planning_slots  slots running work, and all of them
///   strata_build_info{version}                 1
///   process_cpu_seconds_total, process_resident_memory_bytes, process_virtual_memory_bytes,
///   process_open_fds, process_max_fds, process_start_time_seconds  (Prometheus' standard
///                                              process metrics, from /proc at scrape)
#include <memory>
#include <set>
#include <shared_mutex>
#include <string>
#include <string_view>

#include <grpcpp/support/server_interceptor.h>
#include <grpcpp/support/status.h>
#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include "maps/map_registry.hpp"
#include "rpc/planning_slots.hpp"
#include "strata/planner.hpp"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

class Metrics {
 public:
  Metrics();

  /// The text exposition of everything: what a scrape of /metrics returns. Thread-safe.
  std::string Serialize() const;

  /// Interceptor factory for ServerBuilder::experimental().SetInterceptorCreators. It keeps
  /// a pointer to this object, which must outlive the server.
  std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeInterceptorFactory();

  /// Creates the series of one method with zero counts, so dashboards see them before the
  /// first call (as go-grpc-prometheus's InitializeMetrics does), and makes it a method
  /// whose calls are labelled by name. Calls to any other path (a client may send any) are
  /// counted under service and method "unknown", so they cannot grow the exposition.
  void InitializeMethod(std::string_view type, std::string_view service, std::string_view method);

  /// Serves strata_maps{state} and strata_map_memory_bytes from `maps` at each scrape.
  /// Call before serving; `maps` must outlive the serving.
  void WatchMaps(const MapRegistry* maps);
  /// Serves strata_reservations and strata_reservations_expired_total from `schedule` at each
  /// scrape. Call before serving; `schedule` must outlive the serving.
  void WatchReservations(const ReservationSchedule* schedule);
  /// Serves strata_plans_queued and strata_planning_slots{,_busy} from `slots` at each
  /// scrape. Call before serving; `slots` must outlive the serving.
  void WatchPlanningSlots(const PlanningSlots* slots);

  /// One finished plan: `result` is "OK" or the error's reason; timings only on success.
  void RecordPlan(std::string_view result, const PlanTimings* timings);

  /// A map that finished creation (ACTIVE or FAILED).
  void RecordMapDone(const MapSnapshot& map);

  // Used by the interceptor.
  struct MethodLabels {
    std::string type, service, method;
  };
  /// The labels of a call: its service and method when initialised, else "unknown".
  MethodLabels LabelsOf(const grpc::experimental::ServerRpcInfo& info) const;
  void RecordStarted(const MethodLabels& labels);
  void RecordHandled(const MethodLabels& labels, grpc::StatusCode code, double seconds);
  void RecordReceived(const MethodLabels& labels);
  void RecordSent(const MethodLabels& labels);

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>& started_;
  prometheus::Family<prometheus::Counter>& handled_;
  prometheus::Family<prometheus::Counter>& received_;
  prometheus::Family<prometheus::Counter>& sent_;
  prometheus::Family<prometheus::Histogram>& handling_seconds_;
  prometheus::Family<prometheus::Counter>& plans_;
  prometheus::Family<prometheus::Histogram>& plan_seconds_;
  prometheus::Family<prometheus::Histogram>& assessment_seconds_;
  std::shared_ptr<prometheus::Collectable> map_collector_;
  std::shared_ptr<prometheus::Collectable> reservation_collector_;
  std::shared_ptr<prometheus::Collectable> planning_collector_;
  std::shared_ptr<prometheus::Collectable> process_collector_;  // Always.
  mutable std::shared_mutex known_mutex_;
  std::set<std::string, std::less<>> known_methods_;  // "/service/method" of InitializeMethod.
};

}  // namespace strata::server
