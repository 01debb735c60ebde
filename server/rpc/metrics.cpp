#include "rpc/metrics.hpp"

#include "rpc/error_mapping.hpp"
#include "strata/version.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include <prometheus/gauge.h>
#include <prometheus/text_serializer.h>

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;
using grpc::experimental::InterceptionHookPoints;
using grpc::experimental::ServerRpcInfo;

// prometheus.DefBuckets, as go-grpc-prometheus uses for grpc_server_handling_seconds.
const prometheus::Histogram::BucketBoundaries kRpcBuckets = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                             0.5,   1,    2.5,   5,    10};
const prometheus::Histogram::BucketBoundaries kPlanBuckets = {
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};
const prometheus::Histogram::BucketBoundaries kAssessmentBuckets = {
    0.01, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 25, 50, 100, 250, 600};

std::string_view TypeName(ServerRpcInfo::Type type) {
  switch (type) {
    case ServerRpcInfo::Type::UNARY: return "unary";
    case ServerRpcInfo::Type::CLIENT_STREAMING: return "client_stream";
    case ServerRpcInfo::Type::SERVER_STREAMING: return "server_stream";
    case ServerRpcInfo::Type::BIDI_STREAMING: return "bidi_stream";
  }
  return "unary";
}

class MetricsInterceptor final : public grpc::experimental::Interceptor {
 public:
  MetricsInterceptor(Metrics* metrics, Metrics::MethodLabels labels)
      : metrics_(metrics), labels_(std::move(labels)), start_(SteadyClock::now()) {
    metrics_->RecordStarted(labels_);
  }

  ~MetricsInterceptor() override {
    // A call that ended without sending a status (the client went away).
    if (!handled_) metrics_->RecordHandled(labels_, grpc::StatusCode::CANCELLED, Elapsed());
  }

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) &&
        methods->GetRecvMessage() != nullptr) {
      metrics_->RecordReceived(labels_);
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE)) {
      metrics_->RecordSent(labels_);
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      handled_ = true;
      metrics_->RecordHandled(labels_, methods->GetSendStatus().error_code(), Elapsed());
    }
    methods->Proceed();
  }

 private:
  double Elapsed() const {
    return std::chrono::duration<double>(SteadyClock::now() - start_).count();
  }

  Metrics* metrics_;
  Metrics::MethodLabels labels_;
  SteadyClock::time_point start_;
  bool handled_ = false;
};

class MetricsInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit MetricsInterceptorFactory(Metrics* metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(ServerRpcInfo* info) override {
    return new MetricsInterceptor(metrics_, metrics_->LabelsOf(*info));
  }

 private:
  Metrics* metrics_;
};

// Map gauges read from the registry at scrape time, so they are never stale (a map's memory
// grows when a new robot profile first plans on it).
class MapCollector final : public prometheus::Collectable {
 public:
  explicit MapCollector(const MapRegistry* maps) : maps_(maps) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    const MapTotals totals = maps_->Totals();
    prometheus::MetricFamily states{
        "strata_maps", "Maps hosted, by state.", prometheus::MetricType::Gauge, {}};
    const std::pair<const char*, int> counts[] = {
        {"creating", totals.creating}, {"active", totals.active}, {"failed", totals.failed}};
    for (const auto& [state, count] : counts) {
      prometheus::ClientMetric metric;
      metric.label = {{"state", state}};
      metric.gauge.value = count;
      states.metric.push_back(metric);
    }
    prometheus::MetricFamily memory{
        "strata_map_memory_bytes",
        "Bytes held by ACTIVE maps in memory (terrain models and cached traversability "
        "graphs); with a map store, the maps loaded here.",
        prometheus::MetricType::Gauge,
        {}};
    prometheus::ClientMetric bytes;
    bytes.gauge.value = static_cast<double>(totals.active_memory_bytes);
    memory.metric.push_back(bytes);
    prometheus::MetricFamily budget{
        "strata_memory_budget_bytes",
        "--max-memory: the server's memory budget for maps, uploads and maps being made.",
        prometheus::MetricType::Gauge,
        {}};
    prometheus::MetricFamily reserved{
        "strata_memory_reserved_bytes",
        "Bytes of the memory budget set aside beside the maps: uploads (and maps waiting to "
        "be made from them), and --max-assessment-memory for each map being made.",
        prometheus::MetricType::Gauge,
        {}};
    if (const MemoryBudget* memory = maps_->options().memory_budget.get()) {
      prometheus::ClientMetric limit;
      limit.gauge.value = static_cast<double>(memory->limit());
      budget.metric.push_back(limit);
      const std::pair<const char*, MemoryBudget::Use> uses[] = {
          {"uploads", MemoryBudget::Use::kUploads},
          {"assessments", MemoryBudget::Use::kAssessments}};
      for (const auto& [name, use] : uses) {
        prometheus::ClientMetric metric;
        metric.label = {{"use", name}};
        metric.gauge.value = static_cast<double>(memory->reserved(use));
        reserved.metric.push_back(metric);
      }
    }
    // One series per map while it is created, gone once it is ACTIVE or FAILED: at most
    // --max-maps series at a time.
    prometheus::MetricFamily creation{
        "strata_map_creation_progress_ratio",
        "Progress of each map being created, in [0, 1], with the step under way.",
        prometheus::MetricType::Gauge,
        {}};
    for (const CreationProgress& map : totals.creating_progress) {
      prometheus::ClientMetric metric;
      metric.label = {{"map_id", map.id}, {"step", map.step}};
      metric.gauge.value = map.progress;
      creation.metric.push_back(metric);
    }
    return {states, memory, budget, reserved, creation};
  }

 private:
  const MapRegistry* maps_;
};

// A family of one unlabelled series of `type` (a gauge or a counter).
prometheus::MetricFamily OneSeries(std::string name, std::string help, prometheus::MetricType type,
                                   double value) {
  prometheus::MetricFamily family{std::move(name), std::move(help), type, {}};
  prometheus::ClientMetric metric;
  (type == prometheus::MetricType::Counter ? metric.counter.value : metric.gauge.value) = value;
  family.metric.push_back(metric);
  return family;
}

prometheus::MetricFamily OneGauge(std::string name, std::string help, double value) {
  return OneSeries(std::move(name), std::move(help), prometheus::MetricType::Gauge, value);
}

prometheus::MetricFamily OneCounter(std::string name, std::string help, double value) {
  return OneSeries(std::move(name), std::move(help), prometheus::MetricType::Counter, value);
}

// The schedule's figures, read at scrape time.
class ReservationCollector final : public prometheus::Collectable {
 public:
  explicit ReservationCollector(const ReservationSchedule* schedule) : schedule_(schedule) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    return {OneGauge("strata_reservations",
                     "Robots' reservations whose lease has not expired, over all maps.",
                     static_cast<double>(schedule_->size())),
            OneCounter("strata_reservations_expired_total",
                       "Reservations collected because their lease expired.",
                       static_cast<double>(schedule_->collected())),
            OneCounter("strata_reservations_replanned_total",
                       "Reservations this replica replanned to let another robot's plan pass "
                       "first.",
                       static_cast<double>(schedule_->replanned()))};
  }

 private:
  const ReservationSchedule* schedule_;
};

// The planning slots' gauges, read at scrape time.
class PlanningCollector final : public prometheus::Collectable {
 public:
  explicit PlanningCollector(const PlanningSlots* slots) : slots_(slots) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    return {
        OneGauge("strata_plans_queued",
                 "Calls waiting for a planning slot now: above zero, this replica is "
                 "saturated (scale on it).",
                 static_cast<double>(slots_->queued())),
        OneGauge("strata_planning_slots_busy", "Planning slots running work now.", slots_->busy()),
        OneGauge("strata_planning_slots", "Planning slots (--max-concurrent-plans).",
                 slots_->slots())};
  }

 private:
  const PlanningSlots* slots_;
};

// Prometheus' standard process metrics, read from /proc/self at scrape time (as the Go and
// Python clients export them; prometheus-cpp has none).
class ProcessCollector final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override {
    std::vector<prometheus::MetricFamily> families;
    const long ticks = ::sysconf(_SC_CLK_TCK);
    const long page = ::sysconf(_SC_PAGESIZE);
    std::ifstream stat_file("/proc/self/stat");
    std::string stat((std::istreambuf_iterator<char>(stat_file)), {});
    // Fields after the command's closing parenthesis (which may hold spaces): state is 3rd.
    std::istringstream fields(stat.substr(stat.rfind(')') + 2));
    std::vector<std::string> f((std::istream_iterator<std::string>(fields)), {});
    if (f.size() > 21 && ticks > 0) {
      const double cpu_s = (std::stod(f[11]) + std::stod(f[12])) / static_cast<double>(ticks);
      prometheus::MetricFamily cpu{"process_cpu_seconds_total",
                                   "Total user and system CPU time spent in seconds.",
                                   prometheus::MetricType::Counter,
                                   {}};
      prometheus::ClientMetric seconds;
      seconds.counter.value = cpu_s;
      cpu.metric.push_back(seconds);
      families.push_back(std::move(cpu));
      families.push_back(OneGauge("process_virtual_memory_bytes", "Virtual memory size in bytes.",
                                  std::stod(f[20])));
      families.push_back(OneGauge("process_resident_memory_bytes", "Resident memory size in bytes.",
                                  std::stod(f[21]) * static_cast<double>(page)));
      families.push_back(OneGauge("process_start_time_seconds",
                                  "Start time of the process since unix epoch in seconds.",
                                  BootTimeS() + std::stod(f[19]) / static_cast<double>(ticks)));
    }
    std::error_code ec;
    double fds = 0;
    for (std::filesystem::directory_iterator it("/proc/self/fd", ec), end; !ec && it != end;
         it.increment(ec)) {
      ++fds;
    }
    families.push_back(OneGauge("process_open_fds", "Number of open file descriptors.", fds));
    rlimit limit{};
    if (::getrlimit(RLIMIT_NOFILE, &limit) == 0) {
      families.push_back(OneGauge("process_max_fds", "Maximum number of open file descriptors.",
                                  static_cast<double>(limit.rlim_cur)));
    }
    return families;
  }

 private:
  // The system's boot time [s since the epoch] (/proc/stat's btime).
  static double BootTimeS() {
    std::ifstream in("/proc/stat");
    for (std::string key; in >> key;) {
      if (key == "btime") {
        double boot = 0;
        in >> boot;
        return boot;
      }
      in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
    }
    return 0;
  }
};

}  // namespace

Metrics::Metrics()
    : registry_(std::make_shared<prometheus::Registry>()),
      started_(prometheus::BuildCounter()
                   .Name("grpc_server_started_total")
                   .Help("Total number of RPCs started on the server.")
                   .Register(*registry_)),
      handled_(prometheus::BuildCounter()
                   .Name("grpc_server_handled_total")
                   .Help("Total number of RPCs completed on the server, regardless of success "
                         "or failure.")
                   .Register(*registry_)),
      received_(prometheus::BuildCounter()
                    .Name("grpc_server_msg_received_total")
                    .Help("Total number of RPC stream messages received on the server.")
                    .Register(*registry_)),
      sent_(prometheus::BuildCounter()
                .Name("grpc_server_msg_sent_total")
                .Help("Total number of gRPC stream messages sent by the server.")
                .Register(*registry_)),
      handling_seconds_(prometheus::BuildHistogram()
                            .Name("grpc_server_handling_seconds")
                            .Help("Histogram of response latency (seconds) of gRPC that had "
                                  "been application-level handled by the server.")
                            .Register(*registry_)),
      plans_(prometheus::BuildCounter()
                 .Name("strata_plans_total")
                 .Help("Plans finished, by result: OK or the error reason.")
                 .Register(*registry_)),
      plan_seconds_(prometheus::BuildHistogram()
                        .Name("strata_plan_duration_seconds")
                        .Help("Wall-clock seconds of successful plans, by stage.")
                        .Register(*registry_)),
      assessment_seconds_(prometheus::BuildHistogram()
                              .Name("strata_map_assessment_seconds")
                              .Help("Wall-clock seconds of map creation, by stage (maps that "
                                    "became ACTIVE).")
                              .Register(*registry_)),
      process_collector_(std::make_shared<ProcessCollector>()) {
  prometheus::BuildGauge()
      .Name("strata_build_info")
      .Help("1, labelled with this server's version and the commit it was built from.")
      .Register(*registry_)
      .Add({{"version", kStrataVersion}, {"commit", kStrataCommit}})
      .Set(1);
}

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
Metrics::MakeInterceptorFactory() {
  return std::make_unique<MetricsInterceptorFactory>(this);
}

std::string Metrics::Serialize() const {
  std::vector<prometheus::MetricFamily> families = registry_->Collect();
  for (const auto& collector :
       {map_collector_, reservation_collector_, planning_collector_, process_collector_}) {
    if (!collector) continue;
    for (auto& family : collector->Collect()) families.push_back(std::move(family));
  }
  return prometheus::TextSerializer().Serialize(families);
}

// "/strata.v1.MapService/GetMap" -> service "strata.v1.MapService", method "GetMap".
Metrics::MethodLabels Metrics::LabelsOf(const ServerRpcInfo& info) const {
  const std::string_view full = info.method() != nullptr ? info.method() : "";
  MethodLabels labels{std::string(TypeName(info.type())), "unknown", "unknown"};
  {
    std::shared_lock lock(known_mutex_);
    if (!known_methods_.contains(full)) return labels;
  }
  const std::size_t slash = full.find('/', 1);
  labels.service = full.substr(1, slash - 1);
  labels.method = full.substr(slash + 1);
  return labels;
}

void Metrics::InitializeMethod(std::string_view type, std::string_view service,
                               std::string_view method) {
  const MethodLabels labels{std::string(type), std::string(service), std::string(method)};
  {
    std::lock_guard lock(known_mutex_);
    known_methods_.insert("/" + labels.service + "/" + labels.method);
  }
  started_.Add({{"grpc_type", labels.type},
                {"grpc_service", labels.service},
                {"grpc_method", labels.method}});
  handling_seconds_.Add({{"grpc_type", labels.type},
                         {"grpc_service", labels.service},
                         {"grpc_method", labels.method}},
                        kRpcBuckets);
}

void Metrics::WatchMaps(const MapRegistry* maps) {
  map_collector_ = std::make_shared<MapCollector>(maps);
}

void Metrics::WatchReservations(const ReservationSchedule* schedule) {
  reservation_collector_ = std::make_shared<ReservationCollector>(schedule);
}

void Metrics::WatchPlanningSlots(const PlanningSlots* slots) {
  planning_collector_ = std::make_shared<PlanningCollector>(slots);
}

void Metrics::RecordPlan(std::string_view result, const PlanTimings* timings) {
  plans_.Add({{"result", std::string(result)}}).Increment();
  if (timings == nullptr) return;
  const std::pair<const char*, double> stages[] = {
      {"graph", timings->graph_s},   {"snap", timings->snap_s},
      {"search", timings->search_s}, {"optimize", timings->optimize_s},
      {"verify", timings->verify_s}, {"total", timings->total_s}};
  for (const auto& [stage, seconds] : stages) {
    plan_seconds_.Add({{"stage", stage}}, kPlanBuckets).Observe(seconds);
  }
}

void Metrics::RecordMapDone(const MapSnapshot& map) {
  if (map.state != MapState::kActive) return;
  const AssessmentTimings& t = map.summary.timings;
  const std::pair<const char*, double> stages[] = {{"load", map.load_s},
                                                   {"ground_filter", t.ground_filter_s},
                                                   {"surfaces", t.surfaces_s},
                                                   {"fields", t.fields_s},
                                                   {"total", t.total_s}};
  for (const auto& [stage, seconds] : stages) {
    assessment_seconds_.Add({{"stage", stage}}, kAssessmentBuckets).Observe(seconds);
  }
}

void Metrics::RecordStarted(const MethodLabels& l) {
  started_.Add({{"grpc_type", l.type}, {"grpc_service", l.service}, {"grpc_method", l.method}})
      .Increment();
}

void Metrics::RecordHandled(const MethodLabels& l, grpc::StatusCode code, double seconds) {
  handled_
      .Add({{"grpc_type", l.type},
            {"grpc_service", l.service},
            {"grpc_method", l.method},
            {"grpc_code", std::string(GoCodeName(code))}})
      .Increment();
  handling_seconds_
      .Add({{"grpc_type", l.type}, {"grpc_service", l.service}, {"grpc_method", l.method}},
           kRpcBuckets)
      .Observe(seconds);
}

void Metrics::RecordReceived(const MethodLabels& l) {
  received_.Add({{"grpc_type", l.type}, {"grpc_service", l.service}, {"grpc_method", l.method}})
      .Increment();
}

void Metrics::RecordSent(const MethodLabels& l) {
  sent_.Add({{"grpc_type", l.type}, {"grpc_service", l.service}, {"grpc_method", l.method}})
      .Increment();
}

}  // namespace strata::server
