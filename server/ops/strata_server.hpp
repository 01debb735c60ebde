#pragma once
/// The assembled server: map registry, services, health, reflection, metrics, preloads.
/// main.cpp adds flags and signals around it; tests may embed it.
#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "common/service_error.hpp"
#include "http/http_api.hpp"
#include "http/http_server.hpp"
#include "http/metrics_page.hpp"
#include "maps/map_registry.hpp"
#include "ops/flags.hpp"
#include "rpc/auth.hpp"
#include "rpc/map_service.hpp"
#include "rpc/metrics.hpp"
#include "rpc/planner_service.hpp"
#include "rpc/planning_slots.hpp"
#include "rpc/recent_plans.hpp"
#include "rpc/reflection_v1.hpp"
#include "rpc/traffic_service.hpp"
#include "shared/etcd_client.hpp"
#include "shared/etcd_map_heads.hpp"
#include "shared/etcd_schedule_ledger.hpp"

namespace strata::server {

/// A --preload checked: its map's source opened (or its scene checked) and its parameters.
struct ResolvedPreload {
  std::string id;
  MapSource source;
  AssessmentConfig config;
  bool config_given = false;  ///< A KEY=VALUE terrain parameter was given.
};

class StrataServer {
 public:
  /// Checks the configuration (map root, preloads), starts listening, and queues the
  /// preloaded maps. Health is NOT_SERVING for "" and strata.v1.PlannerService until every
  /// preloaded map is ACTIVE (it stays so if one FAILS; the log says why). Fails with a
  /// message naming the flag at fault.
  static Result<std::unique_ptr<StrataServer>> Start(const ServerConfig& config);
  ~StrataServer();

  /// Bound gRPC address ("127.0.0.1:50051"), metrics port and viewer port (-1 when
  /// disabled).
  const std::string& address() const { return address_; }
  int metrics_port() const { return metrics_server_ ? metrics_server_->port() : -1; }
  int http_port() const { return http_server_ ? http_server_->port() : -1; }

  /// Health to NOT_SERVING and no new maps; new calls are still served for `drain_delay`
  /// (load balancers stop sending meanwhile); then gRPC shutdown: new calls are refused,
  /// in-flight calls get until `grace` to finish, after which plans stop and answer
  /// SHUTTING_DOWN and any other call is cancelled; the viewer stops accepting at the same
  /// time and finishes its requests alike. Returns when every call has ended.
  /// Thread-safe; idempotent.
  void Shutdown(std::chrono::steady_clock::duration drain_delay,
                std::chrono::steady_clock::duration grace);

  /// Blocks until Shutdown has completed.
  void Wait();

  /// After Shutdown: waits up to `timeout` for a running assessment (which cannot be
  /// interrupted) to end; false if one is still running.
  bool WaitAssessmentsIdle(std::chrono::steady_clock::duration timeout);

  /// Whether a preloaded map failed (with --exit-on-preload-failure the server then shuts
  /// down by itself, and main exits 1).
  bool preload_failed() const;

  MapRegistry& registry() { return *registry_; }
  Metrics& metrics() { return *metrics_; }

 private:
  /// What CheckFlags resolved, for the steps of Start after it.
  struct StartInputs {
    std::filesystem::path map_root;  ///< Canonical; empty without --map-root.
    std::vector<ResolvedPreload> preloads;
    std::shared_ptr<grpc::ServerCredentials> credentials;
  };

  StrataServer() = default;
  // The steps of Start, in its order (strata_server.cpp says why that order).
  Result<StartInputs> CheckFlags();
  ServiceStatus StartMaps(StartInputs* inputs);
  ServiceStatus StartServices(const StartInputs& inputs);
  ServiceStatus Listen(const StartInputs& inputs);
  ServiceStatus ServeMetrics();
  ServiceStatus ServeViewer();
  ServiceStatus QueuePreloads(std::vector<ResolvedPreload>* preloads);
  void OnMapDone(const MapSnapshot& map);
  void SetReady(bool ready);

  ServerConfig config_;
  std::unique_ptr<TokenTable> tokens_;  // --auth-tokens; null when every call is allowed.
  std::shared_ptr<MemoryBudget> memory_budget_;
  // --etcd: the connection to etcd (null without), before everything that calls it.
  std::unique_ptr<EtcdClient> etcd_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<MapRegistry> registry_;
  std::unique_ptr<PlanningSlots> planning_slots_;
  std::unique_ptr<RecentPlans> recent_plans_;
  std::unique_ptr<MapServiceImpl> map_service_;
  std::unique_ptr<ReservationSchedule> reservations_;
  // --etcd: the reservations' ledger there (null without), after the schedule it feeds.
  std::unique_ptr<EtcdScheduleLedger> shared_schedule_;
  std::unique_ptr<PlannerServiceImpl> planner_service_;
  std::unique_ptr<TrafficServiceImpl> traffic_service_;
  std::unique_ptr<ReflectionV1Service> reflection_v1_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<MetricsPage> metrics_page_;
  std::unique_ptr<HttpServer> metrics_server_;  // Null with --metrics-port -1.
  std::unique_ptr<HttpApi> http_api_;
  std::unique_ptr<HttpServer> http_server_;  // Null without --http-port.
  std::string address_;

  mutable std::mutex mutex_;  // Guards the fields below.
  std::set<std::string> pending_preloads_;
  bool preload_failed_ = false;
  bool shutting_down_ = false;
  bool etcd_connected_ = false;  // Whether the shared schedule follows etcd now.
};

}  // namespace strata::server
