// Map-store figures for docs/benchmarks.md ("Map store"), in process, on a fresh temporary
// store: a map created (assessed and written) by one registry, then planned on by a second
// registry on the same store that has never loaded it (the first request loads the saved
// model), against assessing it; edits (an obstacle, a removal, a keep-out zone) and what each
// costs; scans sent at a steady rate while clients plan (--soak-s); and resident memory while
// maps are planned on in turn under a budget. Not part of the test path.
//
//   build/bench/store_benchmark MAP [--resolution M] [--runs N] [--churn-maps N]
//       [--soak-s S [--soak-rate HZ] [--soak-planners N]] [--etcd HOST:PORT]
//       [--map-worker build/server/strata-map-worker] [--max-memory-gb G]
//   With --map-worker maps are made and edited in worker processes, as strata-server makes
//   them (the model and cloud then pass through files); without it, in this process.
//   With --etcd (bench/with_etcd.sh starts a throwaway one) the maps' heads live there, as
//   with strata-server --etcd, and the second replica learns of each edit through its watch.
//       MAP: a cloud file, or scene:NAME[:SEED][:size_m=M] (as strata-offline takes)
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "common/free_memory.hpp"
#include "common/log.hpp"
#include "maps/map_registry.hpp"
#include "maps/map_worker.hpp"
#include "rpc/proto_convert.hpp"
#include "shared/etcd_client.hpp"
#include "shared/etcd_map_heads.hpp"
#include "statistics.hpp"
#include "strata/scenes/map_source.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace strata;
using namespace strata::server;
using strata::bench::Median;
using strata::bench::Quantile;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// --map-worker: maps made and edited in strata-map-worker processes, as strata-server makes
// them; empty: in this process.
std::string map_worker;
// --max-memory-gb: the memory budget of each replica that makes, edits or plans on the map
// (versions let go of past it, as a server's --max-memory does); 0: none.
std::uint64_t replica_budget = 0;

// Shared by every replica's registry, as in a process of its own: the memory kept for the
// next versions counts all their maps (free_memory.hpp).
std::shared_ptr<FreeMemoryReturner> ProcessFreeMemory() {
  static const auto returner = std::make_shared<FreeMemoryReturner>();
  return returner;
}

RegistryOptions StoreOptions(const std::shared_ptr<MapStore>& store, std::uint64_t budget) {
  RegistryOptions options;
  if (!map_worker.empty()) {
    MapWorkerOptions worker;
    worker.program = map_worker;
    worker.memory_bytes = std::uint64_t{16} << 30;
    options.build = MapWorkerBuilder(std::move(worker));
  }
  options.store = store;
  options.memory_budget = std::make_shared<MemoryBudget>(budget);
  options.free_memory = ProcessFreeMemory();
  options.encode_metadata = EncodeMapMetadata;
  options.decode_metadata = DecodeMapMetadata;
  options.load_limits.max_points = 200'000'000;
  return options;
}

// One replica's view of the store: its own etcd connection and heads when `etcd` is set.
struct ReplicaStore {
  std::unique_ptr<EtcdClient> client;
  std::shared_ptr<EtcdMapHeads> heads;
  std::shared_ptr<MapStore> store;
};

ReplicaStore OpenReplicaStore(const std::filesystem::path& root, const std::string& etcd,
                              const std::string& prefix) {
  ReplicaStore replica;
  if (!etcd.empty()) {
    EtcdOptions options;
    options.endpoints = {etcd};
    Result<std::unique_ptr<EtcdClient>> client = EtcdClient::Create(options);
    if (!client.ok()) {
      std::fprintf(stderr, "%s\n", client.error().message.c_str());
      std::exit(1);
    }
    replica.client = std::move(client).value();
    replica.heads = std::make_shared<EtcdMapHeads>(replica.client.get(), prefix);
    if (!replica.heads->WaitUntilRead(std::chrono::seconds(10))) {
      std::fprintf(stderr, "etcd at %s did not answer\n", etcd.c_str());
      std::exit(1);
    }
  }
  Result<std::unique_ptr<MapStore>> opened = MapStore::Open(root, replica.heads);
  if (!opened.ok()) {
    std::fprintf(stderr, "%s\n", opened.error().message.c_str());
    std::exit(1);
  }
  replica.store = std::move(opened).value();
  return replica;
}

server::MapSource SourceOf(const std::string& map) {
  if (map.rfind("scene:", 0) == 0) {
    Expected<SceneSource> scene = ParseSceneSource(map);
    if (!scene) {
      std::fprintf(stderr, "%s\n", scene.error().message.c_str());
      std::exit(2);
    }
    return *scene;
  }
  const std::filesystem::path path = std::filesystem::canonical(map);
  Result<std::shared_ptr<const OpenedMapFile>> file =
      OpenMapFile(path.parent_path(), path.filename().string(), "map");
  if (!file.ok()) {
    std::fprintf(stderr, "%s\n", file.error().message.c_str());
    std::exit(2);
  }
  return FileMapSource{std::move(file).value(), map};
}

MapSnapshot CreateAndWait(MapRegistry& registry, const std::string& id, const std::string& map,
                          const AssessmentConfig& config) {
  Result<MapSnapshot> created = registry.Create(id, SourceOf(map), config, true);
  if (!created.ok()) {
    std::fprintf(stderr, "create %s: %s\n", id.c_str(), created.error().message.c_str());
    std::exit(1);
  }
  Result<MapSnapshot> done = registry.WaitUntilDone(id, Clock::time_point::max(), {});
  if (!done.ok() || done->state != MapState::kActive) {
    std::fprintf(stderr, "%s did not become ACTIVE: %s\n", id.c_str(),
                 done.ok() && done->failure ? done->failure->message.c_str() : "not found");
    std::exit(1);
  }
  return done.value();
}

// The resident anonymous memory in transparent huge pages [bytes] (/proc/self/smaps_rollup).
double HugePagesResidentBytes() {
  std::ifstream rollup("/proc/self/smaps_rollup");
  std::string line;
  while (std::getline(rollup, line)) {
    double kb = 0;
    if (std::sscanf(line.c_str(), "AnonHugePages: %lf kB", &kb) == 1) return kb * 1e3;
  }
  return 0;
}

// What glibc's allocator holds [MB]: in use by live blocks, free inside its arenas (resident
// until trimmed), and mapped for large blocks; and what of the process is in huge pages. Tells
// a growth of live memory from memory the allocator keeps after it was freed, and that from
// huge pages faulted in again where a trim left holes.
std::string AllocatorFigures() {
  const struct mallinfo2 info = mallinfo2();
  return fmt::format(
      "in use {:.0f} MB, free in arenas {:.0f} MB, mapped {:.0f} MB; resident in huge pages "
      "{:.0f} MB",
      static_cast<double>(info.uordblks) / 1e6, static_cast<double>(info.fordblks) / 1e6,
      static_cast<double>(info.hblkhd) / 1e6, HugePagesResidentBytes() / 1e6);
}

// A valid ground point near the middle of the map, and one a few metres away on the same
// level when there is one: a short plan that proves the loaded map plans.
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> ShortQuery(const TerrainModel& model) {
  const GridGeometry& grid = model.grid();
  const auto ground_at = [&](int ix, int iy) -> std::optional<Eigen::Vector3d> {
    for (const ColumnSurface& surface : model.surfaces().Column(ix, iy)) {
      if (!surface.valid) continue;
      return Eigen::Vector3d(grid.origin_m.x() + (ix + 0.5) * grid.resolution_m,
                             grid.origin_m.y() + (iy + 0.5) * grid.resolution_m,
                             surface.ground_z_m + 0.3);
    }
    return std::nullopt;
  };
  const int cx = grid.size.x() / 2, cy = grid.size.y() / 2;
  const int step = static_cast<int>(std::lround(4.0 / grid.resolution_m));
  for (int r = 0; r < std::max(grid.size.x(), grid.size.y()) / 2; ++r) {
    for (int dx = -r; dx <= r; ++dx) {
      const int ix = cx + dx, iy = cy - r;
      if (ix < 0 || iy < 0 || ix + step >= grid.size.x()) continue;
      const auto a = ground_at(ix, iy);
      const auto b = ground_at(ix + step, iy);
      if (a && b && std::abs(a->z() - b->z()) < 0.3) return std::pair{*a, *b};
    }
  }
  return std::nullopt;
}

// The plan every replica makes for `query` (ShortQuery): a differential robot, with time to
// build its graph on a new version (a 1 km site's takes seconds, past the default budget).
PlanRequest ShortPlan(const std::pair<Eigen::Vector3d, Eigen::Vector3d>& query) {
  PlanRequest request;
  request.profile = BuiltinProfile("differential").value();
  request.start.position_m = query.first;
  request.goal.position_m = query.second;
  request.options.time_budget_s = 120;
  return request;
}

int Measure(int argc, char** argv) {
  CLI::App app{"Map-store figures: load on demand against assessing, edits, memory budget."};
  std::string map;
  double resolution_m = 0;
  int runs = 5;
  int churn_maps = 6;
  double soak_s = 0;
  double soak_rate = 5;
  int soak_planners = 8;
  app.add_option("MAP", map, "cloud file or scene:NAME[:SEED][:size_m=M]")->required();
  app.add_option("--resolution", resolution_m, "grid resolution [m]; 0: the default");
  app.add_option("--runs", runs, "loads and edits timed (median reported)");
  app.add_option("--churn-maps", churn_maps, "maps planned on in turn under a budget; 0 skips");
  app.add_option("--soak-s", soak_s,
                 "seconds of planning without scans, then as long with scans; 0 skips");
  app.add_option("--soak-rate", soak_rate, "scans per second sent during the soak");
  app.add_option("--soak-planners", soak_planners, "clients planning during the soak");
  std::string etcd;
  app.add_option("--etcd", etcd, "host:port of a running etcd for the maps' heads");
  app.add_option("--map-worker", map_worker,
                 "strata-map-worker: make and edit maps in worker processes, as strata-server "
                 "does (default: in this process)");
  double max_memory_gb = 0;
  app.add_option("--max-memory-gb", max_memory_gb,
                 "memory budget of each replica [GB], as strata-server's --max-memory (a 1 km "
                 "site's versions and graphs outgrow the machine without one); 0: none");
  std::string log_level = LogLevelName(LogLevel::kInfo);
  app.add_option("--log-level", log_level,
                 "how much the replicas log (debug, info, warning, error)");
  CLI11_PARSE(app, argc, argv);
  LogLevel level;
  if (!ParseLogLevel(log_level, &level)) {
    std::fprintf(stderr, "--log-level: '%s' is not a log level\n", log_level.c_str());
    return 2;
  }
  SetLogLevel(level);
  replica_budget = static_cast<std::uint64_t>(max_memory_gb * 1e9);

  AssessmentConfig config;
  if (resolution_m > 0) config.grid.resolution_m = resolution_m;
  const std::filesystem::path root =
      std::filesystem::temp_directory_path() / ("strata-store-bench-" + std::to_string(getpid()));
  std::filesystem::remove_all(root);
  const std::string prefix = "/strata-store-bench-" + std::to_string(getpid());
  ReplicaStore here = OpenReplicaStore(root, etcd, prefix);
  ReplicaStore there = OpenReplicaStore(root, etcd, prefix);  // The second replica's.
  std::shared_ptr<MapStore> store = here.store;

  // 1. Created on one registry: loaded, assessed, written to the store.
  std::printf("map %s, store %s\n", map.c_str(), root.c_str());
  MapSnapshot created;
  double create_s = 0;
  {
    MapRegistry writer(StoreOptions(store, replica_budget));
    const auto start = Clock::now();
    created = CreateAndWait(writer, "m", map, config);
    create_s = SecondsSince(start);
  }
  const double assess_s = created.summary.timings.total_s;
  std::printf(
      "create: %.3f s (load %.3f s, assess %.3f s, write and publish the rest); %zu "
      "points, model %.1f MB\n",
      create_s, created.load_s, assess_s, created.summary.input_points, created.memory_bytes / 1e6);

  // 2. A registry that never saw it: the first request loads the saved model.
  std::vector<double> first_load_s, cached_s, plan_s;
  std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> query;
  for (int run = 0; run < runs; ++run) {
    MapRegistry reader(StoreOptions(store, replica_budget));
    auto start = Clock::now();
    Result<ActiveMap> active = reader.GetActive("m");
    first_load_s.push_back(SecondsSince(start));
    if (!active.ok()) {
      std::fprintf(stderr, "load: %s\n", active.error().message.c_str());
      return 1;
    }
    start = Clock::now();
    (void)reader.GetActive("m");
    cached_s.push_back(SecondsSince(start));
    if (!query) query = ShortQuery(active.value().map->model());
    if (query) {
      const PlanRequest request = ShortPlan(*query);
      start = Clock::now();
      const Expected<PlanResult> plan = Plan(*active.value().map, request);
      plan_s.push_back(SecondsSince(start));
      if (!plan) std::printf("  plan failed: %s\n", plan.error().message.c_str());
    }
  }
  std::printf(
      "fresh registry, first request (load from the store): median %.3f s over %d "
      "(assessing: %.3f s, %.0fx)\n",
      Median(first_load_s), runs, assess_s, assess_s / Median(first_load_s));
  // The first registry to plan builds the robot's graph and keeps it in the store (the
  // registry's end waits for that write); every later one loads it there instead.
  const std::vector<double> loaded_graph_s(plan_s.size() > 1 ? plan_s.begin() + 1 : plan_s.end(),
                                           plan_s.end());
  std::printf(
      "  next request (held): median %.6f s; first plan after loading: %.3f s building the "
      "graph (the first registry), median %.3f s loading it from the store (the %zu after)\n",
      Median(cached_s), plan_s.empty() ? 0.0 : plan_s.front(),
      loaded_graph_s.empty() ? 0.0 : Median(loaded_graph_s), loaded_graph_s.size());

  // 3. Edits on the version just made, each from the current version.
  if (query) {
    MapRegistry editor(StoreOptions(store, replica_budget));
    const Eigen::Vector3d centre = 0.5 * (query->first + query->second);
    const double ground_z = centre.z() - 0.3;
    // Each run edits another spot of the version the last one made, so every run is a fresh
    // local edit, not a repeat the store already holds: 0.3 m further across the plans' line
    // (ShortQuery's runs along x), so that the edits left by the runs before pile up across
    // it, not onto its goal.
    const auto spot = [&](int run) -> Eigen::Vector3d {
      return centre + Eigen::Vector3d(0, 0.3 * run, 0);
    };
    const auto box = [&](int run) {
      const Eigen::Vector3d mid = spot(run);
      return BoxPrism(
          Eigen::AlignedBox3d(Eigen::Vector3d(mid.x() - 1, mid.y() - 1, ground_z - 0.05),
                              Eigen::Vector3d(mid.x() + 1, mid.y() + 1, ground_z + 1.2)));
    };
    const auto hole = [&](int run) {
      const Eigen::Vector3d mid = spot(run);
      return BoxPrism(
          Eigen::AlignedBox3d(Eigen::Vector3d(mid.x() - 2.5, mid.y() - 2.5, ground_z - 0.5),
                              Eigen::Vector3d(mid.x() + 2.5, mid.y() + 2.5, ground_z + 0.5)));
    };
    // A robot's scan of 10 m x 10 m in which a pallet (1.2 x 1.2 x 1.5 m, its faces sampled
    // every 5 cm) was set down on the passage: the ground it sees is what the map holds there.
    // Centred on `mid` (the soak's lie off the plans' line: they must not cut it).
    const auto scan_area = [&](const Eigen::Vector3d& mid) {
      // Whole columns: the grid's height, less a millimetre to stay inside it.
      const double bottom = created.grid.origin_m.z() + 1e-3;
      const double top = bottom + created.grid.size.z() * created.grid.resolution_m - 2e-3;
      return BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(mid.x() - 5, mid.y() - 5, bottom),
                                          Eigen::Vector3d(mid.x() + 5, mid.y() + 5, top)));
    };
    const Result<PointCloud> base_cloud = store->LoadCloud("m", *store->Current("m"));
    // The scan's points: what `seen` (the base cloud when null) holds in the area, and a pallet
    // at `mid`.
    const auto scan_points = [&](const Eigen::Vector3d& mid, const Prism& area,
                                 const PointCloud* seen = nullptr) {
      auto points = std::make_shared<PointCloud>();
      if (!base_cloud.ok()) return points;
      for (const Eigen::Vector3f& p : seen != nullptr ? *seen : base_cloud.value()) {
        if (area.Contains(p.cast<double>())) points->push_back(p);
      }
      constexpr double kStep = 0.05, kSide = 1.2, kHeight = 1.5;
      for (double a = 0; a <= kSide + 1e-9; a += kStep) {
        for (double z = 0; z <= kHeight + 1e-9; z += kStep) {
          for (const Eigen::Vector2d& xy : {Eigen::Vector2d(a, 0), Eigen::Vector2d(a, kSide),
                                            Eigen::Vector2d(0, a), Eigen::Vector2d(kSide, a)}) {
            points->emplace_back(static_cast<float>(mid.x() - kSide / 2 + xy.x()),
                                 static_cast<float>(mid.y() - kSide / 2 + xy.y()),
                                 static_cast<float>(ground_z + z));
          }
        }
        for (double b = 0; b <= kSide + 1e-9; b += kStep) {  // The top.
          points->emplace_back(static_cast<float>(mid.x() - kSide / 2 + a),
                               static_cast<float>(mid.y() - kSide / 2 + b),
                               static_cast<float>(ground_z + kHeight));
        }
      }
      return points;
    };
    struct Case {
      const char* name;
      MapEdit::Kind kind;
      bool keep_out;
    };
    const Case cases[] = {
        {"obstacle 2 x 2 m", MapEdit::Kind::kAddObstacle, false},
        {"removal 5 x 5 m", MapEdit::Kind::kRemovePoints, false},
        {"scan 10 x 10 m", MapEdit::Kind::kScan, false},
        {"keep-out zone", MapEdit::Kind::kAddObstacle, true},
    };
    // A plan across the edited spot on the new version, right after the update: what a robot
    // sees of the change (a cloud edit makes a new model, whose graph this plan builds).
    // With `timings`, a successful plan's stages go there.
    std::atomic<int> soak_failures_told{0};
    const auto plan_after = [&](bool* planned = nullptr, PlanTimings* timings = nullptr) {
      const Result<ActiveMap> active = editor.GetActive("m");
      const PlanRequest request = ShortPlan(*query);
      const auto start = Clock::now();
      const Expected<PlanResult> plan =
          active.ok() ? Plan(*active.value().map, request)
                      : Expected<PlanResult>(Error{ErrorCode::kInvalidInput, "no map"});
      const double plan_s = SecondsSince(start);
      if (timings != nullptr && plan) *timings = plan->stats.timings;
      if (planned != nullptr) {
        *planned = static_cast<bool>(plan);
        // The soak's first failures say why (a scan may cut the plans' line; anything else is
        // a defect to look into).
        if (!plan && soak_failures_told++ < 3) {
          std::printf("  a soak's plan failed: %s\n", plan.error().message.c_str());
        }
      } else if (!plan) {
        std::printf("  the plan after the edit failed: %s\n", plan.error().message.c_str());
      }
      return plan_s;
    };
    (void)plan_after();  // The first version's graph, built before anything is timed.
    // Another replica (a registry of its own on the same store) on which the robot planned too:
    // its first plan on each new version loads the version, and its graph from the store when
    // the editing replica has written it by then (else it builds it).
    MapRegistry elsewhere(StoreOptions(there.store, replica_budget));
    const auto plan_elsewhere = [&](double* graph_s) {
      const auto start = Clock::now();
      const Result<ActiveMap> active = elsewhere.GetActive("m");
      const PlanRequest request = ShortPlan(*query);
      const Expected<PlanResult> plan =
          active.ok() ? Plan(*active.value().map, request)
                      : Expected<PlanResult>(Error{ErrorCode::kInvalidInput, "no map"});
      *graph_s = plan ? plan->stats.timings.graph_s : 0;
      return SecondsSince(start);
    };
    double ignored_graph_s = 0;
    (void)plan_elsewhere(&ignored_graph_s);
    for (const Case& edit : cases) {
      std::vector<double> load, graphs, apply, reassess, join, write, total, planned, other,
          other_graph, seen;
      std::vector<double> written_mb, tiles_written, tiles_shared, written_per_tile_byte;
      std::int64_t columns = 0;
      bool full = false;
      bool from_tiles = false;
      for (int run = 0; run < runs; ++run) {
        const Prism region = edit.kind == MapEdit::Kind::kAddObstacle ? box(run)
                             : edit.kind == MapEdit::Kind::kScan      ? scan_area(spot(run))
                                                                      : hole(run);
        std::vector<MapEdit> edits;
        std::vector<Prism> keep_out;
        if (edit.keep_out) {
          keep_out.push_back(region);
        } else {
          MapEdit change{edit.kind, region, nullptr};
          if (edit.kind == MapEdit::Kind::kScan) change.points = scan_points(spot(run), region);
          edits.push_back(std::move(change));
        }
        Result<MapUpdate> update =
            editor.Update(MapEditRequest{"m", {}, edits, true, keep_out}, CallControl{});
        if (!update.ok()) {
          std::fprintf(stderr, "%s: %s\n", edit.name, update.error().message.c_str());
          return 1;
        }
        load.push_back(update->load_s);
        graphs.push_back(update->graphs_s);
        apply.push_back(update->edit.apply_s);
        reassess.push_back(update->edit.reassess_s);
        join.push_back(update->edit.join_s);
        write.push_back(update->write_s);
        total.push_back(update->total_s);
        const TileWrites& w = update->writes;
        written_mb.push_back(w.bytes_written / 1e6);
        tiles_written.push_back(w.written);
        tiles_shared.push_back(w.shared);
        // The measure: bytes written over the bytes of the tiles that changed.
        if (w.bytes_written > w.list_bytes) {
          written_per_tile_byte.push_back(double(w.bytes_written) /
                                          double(w.bytes_written - w.list_bytes));
        }
        // When the second replica's view of the head (its etcd watch, or the head file) names
        // the new version, counted from the call's end.
        const auto published = Clock::now();
        const auto seen_there = [&] {
          const Result<std::string> current = there.store->Current("m");
          return current.ok() && current.value() == update->map.version;
        };
        while (!seen_there() && SecondsSince(published) < 10) std::this_thread::yield();
        seen.push_back(SecondsSince(published));
        planned.push_back(plan_after());
        double graph_s = 0;
        other.push_back(plan_elsewhere(&graph_s));
        other_graph.push_back(graph_s);
        columns = update->edit.reassessed_columns;
        full = update->edit.full_reassessment;
        from_tiles = update->edit.from_tiles;
      }
      std::printf(
          "edit %-17s median load %.3f s, apply %.3f s, reassess %.3f s (%lld columns%s%s), "
          "join %.3f s, graphs %.3f s, write %.3f s, total %.3f s; the next plan %.3f s; another "
          "replica sees it %.4f s later%s, its first plan on it %.3f s (its graph %.3f s)\n",
          edit.name, Median(load), Median(apply), Median(reassess), static_cast<long long>(columns),
          full ? ", FULL" : "", from_tiles ? ", from tiles" : "", Median(join), Median(graphs),
          Median(write), Median(total), Median(planned), Median(seen),
          etcd.empty() ? " (head file)" : " (etcd watch)", Median(other), Median(other_graph));
      if (!written_per_tile_byte.empty()) {
        std::printf(
            "  written: median %.2f MB, %.0f tiles written, %.0f shared; bytes written / the "
            "changed tiles' bytes %.3f (target <= 2)\n",
            Median(written_mb), Median(tiles_written), Median(tiles_shared),
            Median(written_per_tile_byte));
      }
    }

    // Scans at a steady rate, as robots send them (none waits for the last one's version),
    // while clients plan without pause: plan latency without scans and with, what became of the
    // scans, resident memory. Each plan runs on a whole published version (GetActive).
    // Spots 0.3 m apart along the plans' line, over and over, 12 m beside it.
    constexpr int kSpots = 40;
    const auto soak_spot = [&](int k) -> Eigen::Vector3d {
      return centre + Eigen::Vector3d(0.3 * k, 12, 0);
    };
    PointCloud strip;  // The base cloud under the spots.
    if (soak_s > 0) {
      struct Phase {
        std::vector<double> plan_s;
        int failed = 0;  // Plans that failed (a scan may cut the plans' line).
        double rss_max = 0;
        double slowest_s = 0;        // The slowest plan (the printed max), to compare with,
        PlanTimings slowest_stages;  // and its stages, where it succeeded: where the time went.
      };
      const auto planning_phase = [&](bool scanning) {
        Phase phase;
        std::mutex mutex;
        std::atomic<bool> running{true};
        std::vector<std::thread> planners;
        for (int i = 0; i < soak_planners; ++i) {
          planners.emplace_back([&] {
            std::vector<double> mine;
            int failed = 0;
            double slowest_s = 0;
            PlanTimings slowest_stages;
            while (running) {
              bool planned = false;
              PlanTimings stages;
              mine.push_back(plan_after(&planned, &stages));
              failed += planned ? 0 : 1;
              if (mine.back() > slowest_s) {
                slowest_s = mine.back();
                slowest_stages = planned ? stages : PlanTimings{};
              }
            }
            std::lock_guard lock(mutex);
            phase.plan_s.insert(phase.plan_s.end(), mine.begin(), mine.end());
            phase.failed += failed;
            if (slowest_s > phase.slowest_s) {
              phase.slowest_s = slowest_s;
              phase.slowest_stages = slowest_stages;
            }
          });
        }
        std::deque<std::future<Result<MapUpdate>>> scans;
        std::vector<double> visible_s;
        std::vector<int> merged;
        int sent = 0, failed = 0, built_ahead = 0;
        const auto collect = [&](bool wait) {
          while (!scans.empty() && (wait || scans.front().wait_for(std::chrono::seconds(0)) ==
                                                std::future_status::ready)) {
            const Result<MapUpdate> update = scans.front().get();
            scans.pop_front();
            if (!update.ok()) {
              ++failed;
              continue;
            }
            visible_s.push_back(update->total_s);
            merged.push_back(update->merged_updates);
            built_ahead += update->graphs_s > 0 ? 1 : 0;
          }
        };
        const auto start = Clock::now();
        const double rss_start = static_cast<double>(ResidentBytes());
        const std::string allocator_start = AllocatorFigures();
        // The least resident memory in each quarter of the soak: each version made raises it
        // for a moment (the new model and graphs beside the old), so growth shows in the lows.
        std::array<double, 4> rss_low;
        rss_low.fill(std::numeric_limits<double>::infinity());
        std::array<double, 4> huge_at_low{};  // Of it, in transparent huge pages.
        auto next = start;
        while (SecondsSince(start) < soak_s) {
          const double rss = static_cast<double>(ResidentBytes());
          phase.rss_max = std::max(phase.rss_max, rss);
          const auto quarter = std::min<std::size_t>(3, SecondsSince(start) / soak_s * 4);
          if (rss < rss_low[quarter]) {
            rss_low[quarter] = rss;
            huge_at_low[quarter] = HugePagesResidentBytes();
          }
          if (scanning) {
            const Eigen::Vector3d mid = soak_spot(sent % kSpots);
            const Prism region = scan_area(mid);
            std::vector<MapEdit> edits{
                MapEdit{MapEdit::Kind::kScan, region, scan_points(mid, region, &strip)}};
            scans.push_back(std::async(std::launch::async, [&editor, edits = std::move(edits)] {
              return editor.Update(MapEditRequest{"m", {}, edits, false, {}}, CallControl{});
            }));
            ++sent;
            collect(false);
            next += std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double>(1.0 / soak_rate));
          } else {
            next += std::chrono::milliseconds(200);
          }
          std::this_thread::sleep_until(next);
        }
        running = false;
        for (std::thread& planner : planners) planner.join();
        collect(true);
        const double rss_end = static_cast<double>(ResidentBytes());
        std::printf(
            "soak %s: %.0f s, %d planners: %zu plans (%d failed), plan p50 %.4f s, p99 %.3f s, "
            "max %.3f s; resident %.0f MB at the start, %.0f MB at most, %.0f MB at the end\n",
            scanning ? "with scans" : "without scans", soak_s, soak_planners, phase.plan_s.size(),
            phase.failed, Median(phase.plan_s), Quantile(phase.plan_s, 0.99),
            phase.plan_s.empty() ? 0.0
                                 : *std::max_element(phase.plan_s.begin(), phase.plan_s.end()),
            rss_start / 1e6, phase.rss_max / 1e6, rss_end / 1e6);
        const PlanTimings& slow = phase.slowest_stages;
        std::printf(
            "  the slowest plan's stages: graph %.3f, snap %.3f, search %.3f, optimise %.3f, "
            "verify %.3f, in all %.3f s (in Plan; the rest before it and after)\n",
            slow.graph_s, slow.snap_s, slow.search_s, slow.optimize_s, slow.verify_s, slow.total_s);
        std::printf("  allocator at the start: %s; at the end: %s\n", allocator_start.c_str(),
                    AllocatorFigures().c_str());
        std::printf(
            "  resident at its least in each quarter: %.0f, %.0f, %.0f, %.0f MB (in huge pages "
            "%.0f, %.0f, %.0f, %.0f MB)\n",
            rss_low[0] / 1e6, rss_low[1] / 1e6, rss_low[2] / 1e6, rss_low[3] / 1e6,
            huge_at_low[0] / 1e6, huge_at_low[1] / 1e6, huge_at_low[2] / 1e6, huge_at_low[3] / 1e6);
        if (scanning) {
          double versions = 0;  // Each version's merged calls each count 1/merged of it.
          for (const int m : merged) versions += 1.0 / m;
          std::printf(
              "  scans: %d sent at %.1f/s, %zu landed, %d failed, in %.0f versions (%.1f scans "
              "each); sent to visible p50 %.3f s, p99 %.3f s; %d of the scans' versions had "
              "graphs built ahead\n",
              sent, soak_rate, visible_s.size(), failed, versions,
              versions > 0 ? static_cast<double>(visible_s.size()) / versions : 0.0,
              Median(visible_s), Quantile(visible_s, 0.99), built_ahead);
        }
        return phase;
      };
      const Phase quiet = planning_phase(false);
      // The base cloud's points under every spot, once: sending 5 scans a second must not
      // wait for a pass over a site's 17 M points per scan.
      strip.clear();
      Eigen::AlignedBox3d spots = scan_area(soak_spot(0)).Bounds();
      spots.extend(scan_area(soak_spot(kSpots - 1)).Bounds());
      if (base_cloud.ok()) {
        for (const Eigen::Vector3f& p : base_cloud.value()) {
          if (spots.contains(p.cast<double>())) strip.push_back(p);
        }
      }
      const Phase busy = planning_phase(true);
      std::printf("  plan p99 with scans / without: %.1fx\n",
                  Quantile(quiet.plan_s, 0.99) > 0
                      ? Quantile(busy.plan_s, 0.99) / Quantile(quiet.plan_s, 0.99)
                      : 0.0);
    }
  }

  // 4. Maps planned on in turn by a registry that holds about 40% of them.
  if (churn_maps > 0) {
    {
      MapRegistry writer(StoreOptions(store, replica_budget));
      for (int i = 0; i < churn_maps; ++i) {
        CreateAndWait(writer, "churn" + std::to_string(i),
                      "scene:uneven_terrain:" + std::to_string(i + 1), {});
      }
    }
    std::uint64_t largest = 0;
    {
      MapRegistry sizer(StoreOptions(store, 0));
      for (int i = 0; i < churn_maps; ++i) {
        Result<MapSnapshot> got = sizer.Get("churn" + std::to_string(i));
        if (got.ok()) largest = std::max<std::uint64_t>(largest, got->memory_bytes);
      }
    }
    // Room for 40% of the maps, and never less than one and a half (with fewer than four maps
    // 40% would not hold the largest, and every load would be refused).
    const std::uint64_t budget =
        static_cast<std::uint64_t>(std::max(0.4 * churn_maps, 1.5) * static_cast<double>(largest));
    MapRegistry reader(StoreOptions(store, budget));
    std::uint64_t peak = 0;
    std::vector<double> request_s;
    for (int round = 0; round < 5; ++round) {
      for (int i = 0; i < churn_maps; ++i) {
        const auto start = Clock::now();
        if (!reader.GetActive("churn" + std::to_string((i * 7 + round) % churn_maps)).ok()) {
          std::fprintf(stderr, "churn: a map failed to load\n");
          return 1;
        }
        request_s.push_back(SecondsSince(start));
        peak = std::max<std::uint64_t>(peak, reader.Totals().active_memory_bytes);
      }
    }
    std::printf(
        "churn: %d maps of up to %.1f MB planned on in turn (%zu requests) under a "
        "%.1f MB budget: resident peak %.1f MB; request median %.4f s, max %.3f s\n",
        churn_maps, largest / 1e6, request_s.size(), budget / 1e6, peak / 1e6, Median(request_s),
        *std::max_element(request_s.begin(), request_s.end()));
  }
  // A store's remover thread may still be unlinking an old terrain's tiles: close the stores
  // (their destructors join it) before the directory goes, or remove_all meets a vanished file.
  store.reset();
  for (ReplicaStore* replica : {&here, &there}) {  // Each store before the heads it reads.
    replica->store.reset();
    replica->heads.reset();
    replica->client.reset();
  }
  std::filesystem::remove_all(root);
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  strata::server::RunWithHugePagesForLargeBlocks(argv);  // As strata-server does.
  strata::server::KeepFreedMemoryForReuse();
  // On a thread of its own, as a server's calls are: glibc serves the main thread's malloc
  // from an arena of its own, which behaves unlike the others (free_memory.hpp).
  int code = 0;
  std::thread([&] { code = Measure(argc, argv); }).join();
  return code;
}
