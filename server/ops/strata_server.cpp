#include "ops/strata_server.hpp"

#include <condition_variable>
#include <fstream>
#include <iterator>
#include <thread>

#include <google/protobuf/descriptor.h>
#include <grpc/grpc.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "common/log.hpp"
#include "common/map_id.hpp"
#include "maps/map_root.hpp"
#include "maps/map_worker.hpp"
#include "rpc/proto_convert.hpp"

namespace strata::server {
namespace {

constexpr const char* kServices[] = {"strata.v1.MapService", "strata.v1.PlannerService",
                                     "strata.v1.TrafficService"};

Result<ResolvedPreload> ResolvePreload(const PreloadSpec& spec,
                                       const std::filesystem::path& map_root,
                                       std::size_t max_points) {
  const std::string flag = "--preload " + spec.id;
  auto fail = [&](const ServiceError& error) {
    return MakeError(ErrorCode::kInvalidInput, flag + ": " + error.message);
  };
  if (ServiceStatus valid = ValidateMapId(spec.id); !valid.ok()) {
    return fail(valid.error());
  }
  ResolvedPreload preload{spec.id, SceneMapSource{}, {}};
  if (spec.scene) {
    // The same checks as a CreateMap request for the scene.
    v1::CreateMapRequest request;
    v1::SceneSource* scene = request.mutable_scene();
    scene->set_name(spec.scene->name);
    scene->set_seed(spec.scene->seed);
    if (spec.scene->options.size_m) scene->set_size_m(*spec.scene->options.size_m);
    if (spec.scene->options.spacing_m) scene->set_spacing_m(*spec.scene->options.spacing_m);
    Result<MapSource> source = SourceFromRequest(request, map_root, max_points);
    if (!source.ok()) return fail(source.error());
    preload.source = std::move(source).value();
  } else {
    Result<std::shared_ptr<const OpenedMapFile>> file = OpenMapFile(map_root, spec.path, "preload");
    if (!file.ok()) return fail(file.error());
    preload.source = FileMapSource{std::move(file).value(), spec.path};
  }
  v1::TerrainParameters terrain;
  if (spec.resolution_m) terrain.set_resolution_m(*spec.resolution_m);
  if (spec.ground_radius_m) terrain.set_ground_radius_m(*spec.ground_radius_m);
  if (spec.max_tilt_rad) terrain.set_max_tilt_rad(*spec.max_tilt_rad);
  Result<AssessmentConfig> config = FromProto(terrain, "terrain");
  if (!config.ok()) return fail(config.error());
  preload.config = config.value();
  preload.config_given = terrain.ByteSizeLong() > 0;
  return preload;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Plaintext, TLS (--tls-cert, --tls-key) or mutual TLS (and --tls-client-ca).
Result<std::shared_ptr<grpc::ServerCredentials>> ServerCredentialsFor(const ServerConfig& config) {
  if (config.tls_cert.empty() != config.tls_key.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--tls-cert and --tls-key go together: give both for TLS, or neither");
  }
  if (config.tls_cert.empty()) {
    if (!config.tls_client_ca.empty()) {
      return MakeError(ErrorCode::kInvalidInput,
                       "--tls-client-ca needs TLS: give --tls-cert and --tls-key too");
    }
    if (!config.auth_tokens.empty()) {
      LogWarning("plaintext_tokens")
          .Add("message",
               "--auth-tokens without TLS: tokens cross the network in the clear; give "
               "--tls-cert and --tls-key");
    }
    return grpc::InsecureServerCredentials();
  }
  grpc::SslServerCredentialsOptions options(
      config.tls_client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                                   : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair{ReadFile(config.tls_key),
                                                         ReadFile(config.tls_cert)};
  if (pair.private_key.empty() || pair.cert_chain.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--tls-cert / --tls-key: cannot read a PEM certificate and key there");
  }
  options.pem_key_cert_pairs.push_back(std::move(pair));
  if (!config.tls_client_ca.empty()) {
    options.pem_root_certs = ReadFile(config.tls_client_ca);
    if (options.pem_root_certs.empty()) {
      return MakeError(ErrorCode::kInvalidInput, "--tls-client-ca: cannot read a PEM file there");
    }
  }
  return grpc::SslServerCredentials(options);
}

// "0.0.0.0:0" with port 43125 bound -> "0.0.0.0:43125".
std::string BoundAddress(const std::string& listen, int port) {
  return listen.substr(0, listen.rfind(':')) + ":" + std::to_string(port);
}

}  // namespace

// Start-up order, each step a function below:
//   1. CheckFlags: everything the flags name (map root, preloads, tokens, TLS files) is
//      checked before anything runs, so that a bad flag costs nothing and names itself;
//   2. StartMaps: the memory budget, the metrics, the map registry with its worker and store;
//   3. StartServices: the planning slots, the recent plans, the two services, a metric series
//      for every method;
//   4. Listen: the gRPC port (health NOT_SERVING until the preloads are ACTIVE);
//   5. ServeMetrics, ServeViewer: the metrics and the web viewer, on ports of their own;
//   6. QueuePreloads: last, so that their progress shows through all of the above.
Result<std::unique_ptr<StrataServer>> StrataServer::Start(const ServerConfig& config) {
  std::unique_ptr<StrataServer> self(new StrataServer());
  self->config_ = config;
  Result<StartInputs> inputs = self->CheckFlags();
  if (!inputs.ok()) return std::move(inputs).error();
  StartInputs& checked = inputs.value();
  if (ServiceStatus done = self->StartMaps(&checked); !done.ok()) return std::move(done).error();
  if (ServiceStatus done = self->StartServices(checked); !done.ok()) return std::move(done).error();
  if (ServiceStatus done = self->Listen(checked); !done.ok()) return std::move(done).error();
  if (ServiceStatus done = self->ServeMetrics(); !done.ok()) return std::move(done).error();
  if (ServiceStatus done = self->ServeViewer(); !done.ok()) return std::move(done).error();
  if (ServiceStatus done = self->QueuePreloads(&checked.preloads); !done.ok()) {
    return std::move(done).error();
  }
  return self;
}

Result<StrataServer::StartInputs> StrataServer::CheckFlags() {
  const ServerConfig& config = config_;
  StartInputs inputs;
  if (!config.map_root.empty()) {
    Result<std::filesystem::path> root = CanonicalMapRoot(config.map_root);
    if (!root.ok())
      return MakeError(ErrorCode::kInvalidInput, "--map-root: " + root.error().message);
    inputs.map_root = root.value();
  }
  for (const PreloadSpec& spec : config.preload) {
    Result<ResolvedPreload> preload = ResolvePreload(spec, inputs.map_root, config.max_points);
    if (!preload.ok()) return std::move(preload).error();
    inputs.preloads.push_back(std::move(preload).value());
  }
  if (!config.auth_tokens.empty()) {
    Result<TokenTable> tokens = TokenTable::Load(config.auth_tokens);
    if (!tokens.ok()) {
      return MakeError(ErrorCode::kInvalidInput, "--auth-tokens: " + tokens.error().message);
    }
    tokens_ = std::make_unique<TokenTable>(std::move(tokens).value());
  }
  Result<std::shared_ptr<grpc::ServerCredentials>> credentials = ServerCredentialsFor(config);
  if (!credentials.ok()) return std::move(credentials).error();
  inputs.credentials = std::move(credentials).value();
  return inputs;
}

ServiceStatus StrataServer::StartMaps(StartInputs* inputs) {
  const ServerConfig& config = config_;
  std::vector<ResolvedPreload>& preloads = inputs->preloads;
  memory_budget_ = std::make_shared<MemoryBudget>(
      config.max_memory_bytes > 0 ? config.max_memory_bytes : AutomaticMemoryLimit());
  RegistryOptions registry_options;
  registry_options.max_concurrent_assessments = config.max_concurrent_assessments;
  registry_options.max_maps = config.max_maps;
  registry_options.assessment_threads = config.assessment_threads;
  registry_options.load_limits.max_points = config.max_points;
  // Every new map is made in a worker process of its own: a reader that crashes on a
  // malformed file, or an assessment past its memory or time, fails that map only.
  MapWorkerOptions worker;
  worker.program = config.map_worker.empty() ? MapWorkerBesideThisProgram()
                                             : std::filesystem::path(config.map_worker);
  if (worker.program.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--map-worker: there is no strata-map-worker beside strata-server; give "
                     "its path");
  }
  worker.memory_bytes = config.max_assessment_memory_bytes;
  // The wall-clock limit is the registry's; CPU time is a backstop at every core busy for it.
  const unsigned threads = config.assessment_threads > 0
                               ? static_cast<unsigned>(config.assessment_threads)
                               : std::max(1u, std::thread::hardware_concurrency());
  worker.cpu_s = config.max_assessment_time_s * threads + 10;
  registry_options.build = MapWorkerBuilder(std::move(worker));
  registry_options.max_assessment_time_s = config.max_assessment_time_s;
  if (const std::uint64_t limit = memory_budget_->limit();
      limit > 0 && config.max_assessment_memory_bytes > limit) {
    // A replica that only serves maps from the store needs no room to make one.
    LogWarning("no_room_to_make_maps")
        .Add("message", "--max-assessment-memory " +
                            MebibytesText(config.max_assessment_memory_bytes) +
                            " is more than the whole memory budget (--max-memory " +
                            MebibytesText(limit) + "): this server will refuse to make maps");
  }
  registry_options.memory_budget = memory_budget_;
  registry_options.assessment_memory_bytes = config.max_assessment_memory_bytes;
  registry_options.max_graph_bytes = config.max_graph_memory_bytes;
  std::shared_ptr<EtcdMapHeads> shared_heads;
  if (!config.etcd.empty()) {
    Result<std::vector<std::string>> endpoints = EtcdOptions::ParseEndpoints(config.etcd);
    if (!endpoints.ok()) return std::move(endpoints).error();
    EtcdOptions etcd;
    etcd.endpoints = std::move(endpoints).value();
    etcd.ca_file = config.etcd_ca;
    etcd.cert_file = config.etcd_cert;
    etcd.key_file = config.etcd_key;
    Result<std::unique_ptr<EtcdClient>> client = EtcdClient::Create(etcd);
    if (!client.ok()) return std::move(client).error();
    etcd_ = std::move(client).value();
    if (!config.map_store.empty()) {
      // The maps' heads on etcd: read once before the store is opened (its leftovers are
      // judged against them); while etcd is unreachable the store answers
      // MAP_STORE_UNAVAILABLE and the watch keeps trying.
      shared_heads = std::make_shared<EtcdMapHeads>(etcd_.get(), config.etcd_prefix);
      if (!shared_heads->WaitUntilRead(std::chrono::seconds(10))) {
        LogWarning("etcd_unreachable")
            .Add("endpoints", etcd_->endpoints_text())
            .Add("message",
                 "the maps' heads could not be read within 10 s: maps in the store "
                 "are unavailable until etcd answers");
      }
    }
  }
  if (!config.map_store.empty()) {
    Result<std::unique_ptr<MapStore>> store = MapStore::Open(config.map_store, shared_heads);
    if (!store.ok()) {
      return MakeError(ErrorCode::kInvalidInput, "--map-store: " + store.error().message);
    }
    registry_options.store = std::move(store).value();
    registry_options.versions_kept = config.map_versions_kept;
    registry_options.encode_metadata = EncodeMapMetadata;
    registry_options.decode_metadata = DecodeMapMetadata;
    // A map the store holds already is served from there (loaded on its first request): a
    // new replica assesses nothing at start.
    std::erase_if(preloads, [&](const ResolvedPreload& preload) {
      if (!registry_options.store->Current(preload.id).ok()) return false;
      LogInfo("preload_in_store").Add("map", preload.id);
      return true;
    });
  }
  metrics_ = std::make_unique<Metrics>();
  registry_ = std::make_unique<MapRegistry>(registry_options,
                                            [this](const MapSnapshot& map) { OnMapDone(map); });
  metrics_->WatchMaps(registry_.get());
  return OkStatus();
}

ServiceStatus StrataServer::StartServices(const StartInputs& inputs) {
  const ServerConfig& config = config_;
  planning_slots_ = std::make_unique<PlanningSlots>(
      config.max_concurrent_plans > 0
          ? config.max_concurrent_plans
          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())),
      config.max_queued_plans, config.max_plan_time_s);
  metrics_->WatchPlanningSlots(planning_slots_.get());
  recent_plans_ = std::make_unique<RecentPlans>();
  reservations_ = std::make_unique<ReservationSchedule>(
      ScheduleLimits{.max_reservations_per_map = config.max_reservations,
                     .default_lease_s = config.default_lease_s,
                     .max_lease_s = config.max_lease_s,
                     .max_horizon_s = config.max_reservation_horizon_s,
                     .default_separation_m = config.separation_m});
  metrics_->WatchReservations(reservations_.get());
  if (etcd_) {
    // The traffic service is SERVING while reservations can be committed: while etcd is
    // unreachable, plans are still answered and commits fail with SHARED_STATE_UNAVAILABLE.
    shared_schedule_ = std::make_unique<EtcdScheduleLedger>(
        etcd_.get(), config.etcd_prefix, reservations_.get(), [this](bool connected) {
          std::lock_guard lock(mutex_);
          etcd_connected_ = connected;
          if (server_ != nullptr && !shutting_down_) {
            server_->GetHealthCheckService()->SetServingStatus(kServices[2], connected);
          }
        });
  }
  MapServiceOptions map_options;
  map_options.map_root = inputs.map_root;
  map_options.max_points = config.max_points;
  map_options.tokens = tokens_.get();
  map_options.memory_budget = memory_budget_.get();
  map_options.planning_slots = planning_slots_.get();
  map_options.max_send_message_bytes = static_cast<std::uint64_t>(config.max_send_message_bytes);
  map_options.reservations = reservations_.get();
  map_service_ = std::make_unique<MapServiceImpl>(registry_.get(), map_options);
  PlannerServiceOptions planner_options;
  planner_options.slots = planning_slots_.get();
  planner_options.recent_plans = recent_plans_.get();
  planner_options.max_samples = kMaxResponseSamples;
  planner_options.max_cost_cells = config.max_cost_cells;
  planner_options.max_batch_plans = config.max_batch_plans;
  planner_options.tokens = tokens_.get();
  planner_options.reservations = reservations_.get();
  planner_service_ =
      std::make_unique<PlannerServiceImpl>(registry_.get(), metrics_.get(), planner_options);
  traffic_service_ = std::make_unique<TrafficServiceImpl>(registry_.get(), reservations_.get(),
                                                          planning_slots_.get(), tokens_.get());

  // Every method served gets its own metric series before the first call; calls to any
  // other path are counted as "unknown" (Metrics::InitializeMethod).
  const auto* pool = google::protobuf::DescriptorPool::generated_pool();
  for (const char* name :
       {kServices[0], kServices[1], kServices[2], "grpc.health.v1.Health",
        "grpc.reflection.v1alpha.ServerReflection", "grpc.reflection.v1.ServerReflection"}) {
    const google::protobuf::ServiceDescriptor* service = pool->FindServiceByName(name);
    for (int i = 0; service != nullptr && i < service->method_count(); ++i) {
      const google::protobuf::MethodDescriptor* method = service->method(i);
      const char* type = method->client_streaming()
                             ? (method->server_streaming() ? "bidi_stream" : "client_stream")
                             : (method->server_streaming() ? "server_stream" : "unary");
      metrics_->InitializeMethod(type, name, method->name());
    }
  }
  return OkStatus();
}

ServiceStatus StrataServer::Listen(const StartInputs& inputs) {
  const ServerConfig& config = config_;
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(config.listen, inputs.credentials, &port);
  // gRPC turns SO_REUSEPORT on unless told otherwise: a second server on a taken port would
  // start and take a share of its calls at random.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, config.reuse_port ? 1 : 0);
  builder.SetMaxReceiveMessageSize(config.max_receive_message_bytes);
  builder.SetMaxSendMessageSize(config.max_send_message_bytes);
  // Robots on Wi-Fi: notice dead links within keepalive time + timeout, keep idle
  // connections (and NAT entries) alive, and let clients ping often without being cut off.
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS,
                             static_cast<int>(config.keepalive_time_s * 1000));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS,
                             static_cast<int>(config.keepalive_timeout_s * 1000));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 5000);
  // A client keeps one HTTP/2 connection for as long as it lives: without an age limit, the
  // replicas a scale-out adds would get no calls from clients already connected.
  if (config.max_connection_age_s > 0) {
    builder.AddChannelArgument(
        GRPC_ARG_MAX_CONNECTION_AGE_MS,
        static_cast<int>(std::min(config.max_connection_age_s * 1000, double{INT_MAX})));
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS,
                               static_cast<int>(config.shutdown_grace_s * 1000));
  }
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
  creators.push_back(metrics_->MakeInterceptorFactory());
  builder.experimental().SetInterceptorCreators(std::move(creators));
  builder.RegisterService(map_service_.get());
  builder.RegisterService(planner_service_.get());
  builder.RegisterService(traffic_service_.get());
  reflection_v1_ = std::make_unique<ReflectionV1Service>(std::vector<std::string>{
      kServices[0], kServices[1], kServices[2], "grpc.health.v1.Health",
      "grpc.reflection.v1alpha.ServerReflection", "grpc.reflection.v1.ServerReflection"});
  builder.RegisterService(reflection_v1_.get());
  {
    std::lock_guard lock(mutex_);  // The etcd ledger's thread reads it.
    server_ = builder.BuildAndStart();
  }
  if (!server_ || port == 0) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--listen " + config.listen +
                         ": cannot listen there (address in use by another process, or not a "
                         "local address" +
                         (config.tls_cert.empty()
                              ? std::string(")")
                              : std::string("; or --tls-cert and --tls-key are not a matching "
                                            "PEM certificate and key)")));
  }
  address_ = BoundAddress(config.listen, port);
  {
    std::lock_guard lock(mutex_);
    for (const ResolvedPreload& preload : inputs.preloads) pending_preloads_.insert(preload.id);
  }
  server_->GetHealthCheckService()->SetServingStatus(kServices[0], true);
  {
    std::lock_guard lock(mutex_);
    server_->GetHealthCheckService()->SetServingStatus(kServices[2],  // Traffic.
                                                       config.etcd.empty() || etcd_connected_);
  }
  SetReady(inputs.preloads.empty());
  return OkStatus();
}

ServiceStatus StrataServer::ServeMetrics() {
  const ServerConfig& config = config_;
  if (config.metrics_port >= 0) {
    metrics_page_ = std::make_unique<MetricsPage>(metrics_.get());
    HttpServerOptions options;
    options.address = config.metrics_address;
    options.port = config.metrics_port;
    options.serves = "metrics";
    options.flags = "--metrics-address, --metrics-port";
    Result<std::unique_ptr<HttpServer>> started = HttpServer::Start(options, metrics_page_.get());
    if (!started.ok()) return std::move(started).error();
    metrics_server_ = std::move(started).value();
  }
  return OkStatus();
}

ServiceStatus StrataServer::ServeViewer() {
  const ServerConfig& config = config_;
  if (config.http_port >= 0) {
    // The viewer serves plain HTTP only: with TLS on the gRPC side it is served on loopback
    // only, where no token crosses the network in the clear.
    if (!config.tls_cert.empty() && !IsLoopbackAddress(config.http_address)) {
      return MakeError(
          ErrorCode::kInvalidInput,
          "--http-port with --tls-cert: the web viewer serves plain HTTP only, and plain "
          "HTTP beside a TLS gRPC port would send tokens in the clear: give --http-address "
          "127.0.0.1 and put a TLS-terminating "
          "proxy (or an SSH tunnel) in front of it, or drop --http-port");
    }
    http_api_ =
        std::make_unique<HttpApi>(registry_.get(), map_service_.get(), planner_service_.get(),
                                  traffic_service_.get(), tokens_.get());
    HttpServerOptions http;
    http.address = config.http_address;
    http.port = config.http_port;
    // The same request limit as gRPC's (a JSON body is larger than the binary message, so a
    // request near the limit passes gRPC and not here: the limit is the server's memory's).
    http.max_body_bytes = static_cast<std::size_t>(config.max_receive_message_bytes);
    Result<std::unique_ptr<HttpServer>> started = HttpServer::Start(http, http_api_.get());
    if (!started.ok()) return std::move(started).error();
    http_server_ = std::move(started).value();
  }
  return OkStatus();
}

ServiceStatus StrataServer::QueuePreloads(std::vector<ResolvedPreload>* preloads) {
  for (ResolvedPreload& preload : *preloads) {
    LogInfo("map_queued").Add("map", preload.id).Add("source", "preload");
    Result<MapSnapshot> created = registry_->Create(preload.id, std::move(preload.source),
                                                    preload.config, preload.config_given);
    if (!created.ok()) {
      return MakeError(ErrorCode::kInvalidInput,
                       "--preload " + preload.id + ": " + created.error().message);
    }
  }
  return OkStatus();
}

StrataServer::~StrataServer() {
  // Their requests use the registry.
  if (http_server_) http_server_->Stop();
  if (metrics_server_) metrics_server_->Stop();
  {
    std::lock_guard lock(mutex_);
    shutting_down_ = true;  // Workers finishing now must not touch the health service.
  }
  registry_.reset();
}

bool StrataServer::preload_failed() const {
  std::lock_guard lock(mutex_);
  return preload_failed_;
}

void StrataServer::SetReady(bool ready) {
  // The overall status ("") is SERVING only while the planner service is: set last on the
  // way up and first on the way down, so that a client that saw it SERVING (as a readiness
  // probe or a test waits for it) finds the planner service SERVING too.
  grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService();
  if (ready) {
    health->SetServingStatus(kServices[1], true);
    health->SetServingStatus("", true);
  } else {
    health->SetServingStatus("", false);
    health->SetServingStatus(kServices[1], false);
  }
}

void StrataServer::OnMapDone(const MapSnapshot& map) {
  metrics_->RecordMapDone(map);
  if (map.state == MapState::kActive) {
    LogInfo("map_active")
        .Add("map", map.id)
        .Add("points", map.summary.input_points)
        .Add("valid_ground_points", map.summary.valid_ground_points)
        .Add("load_s", map.load_s)
        .Add("assessment_s", map.summary.timings.total_s)
        .Add("memory_bytes", map.memory_bytes);
  } else {
    LogWarning("map_failed")
        .Add("map", map.id)
        .Add("message", map.failure.has_value() ? map.failure->message : "");
  }
  std::lock_guard lock(mutex_);
  if (pending_preloads_.erase(map.id) == 0 || shutting_down_) return;
  if (map.state != MapState::kActive) {
    preload_failed_ = true;
    LogError("preload_failed")
        .Add("map", map.id)
        .Add("message", config_.exit_on_preload_failure
                            ? "a preloaded map failed: exiting (--exit-on-preload-failure); "
                              "fix --preload"
                            : "a preloaded map failed: health stays NOT_SERVING; fix --preload");
    if (config_.exit_on_preload_failure) {
      // Not on this thread, which the registry's assessment runs on and Shutdown waits for.
      std::thread([this] {
        Shutdown(std::chrono::seconds(0),
                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(config_.shutdown_grace_s)));
      }).detach();
    }
  }
  if (pending_preloads_.empty() && !preload_failed_) {
    SetReady(true);
    LogInfo("ready").Add("message", "every preloaded map is ACTIVE: health is SERVING");
  }
}

void StrataServer::Shutdown(std::chrono::steady_clock::duration drain_delay,
                            std::chrono::steady_clock::duration grace) {
  {
    std::lock_guard lock(mutex_);
    if (shutting_down_) return;
    shutting_down_ = true;
    server_->GetHealthCheckService()->SetServingStatus(false);
  }
  registry_->Shutdown();
  std::this_thread::sleep_for(drain_delay);
  reservations_->Close();  // Schedule watches end now, not at the grace's end.
  // At the grace's end, plans stop and answer SHUTTING_DOWN; gRPC cancels what is left a
  // moment later, once they have had time to send that answer.
  constexpr auto kAnswerTime = std::chrono::milliseconds(500);
  std::mutex done_mutex;
  std::condition_variable done_cv;
  bool done = false;
  std::thread stopper([&] {
    std::unique_lock lock(done_mutex);
    if (!done_cv.wait_for(lock, grace, [&] { return done; })) planning_slots_->Stop();
  });
  // The viewer stops accepting now too; its requests in flight end as gRPC's do (a plan at
  // the grace's end).
  std::thread http_stopper([this] {
    if (http_server_) http_server_->Stop();
  });
  server_->Shutdown(std::chrono::system_clock::now() +
                    std::chrono::duration_cast<std::chrono::system_clock::duration>(grace) +
                    kAnswerTime);
  http_stopper.join();
  {
    std::lock_guard lock(done_mutex);
    done = true;
  }
  done_cv.notify_one();
  stopper.join();
}

void StrataServer::Wait() { server_->Wait(); }

bool StrataServer::WaitAssessmentsIdle(std::chrono::steady_clock::duration timeout) {
  return registry_->WaitIdle(std::chrono::steady_clock::now() + timeout);
}

}  // namespace strata::server
