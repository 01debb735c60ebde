// Site-scale figures for docs/benchmarks.md ("Site-scale maps"): the outdoor_site scene of a
// given side assessed with every core, its memory per column of valid ground and the peak
// RSS, the differential robot's surface graph, a saved model written and loaded back, and
// plans of a few metres and across the site. One site per process, so that the peak RSS is
// that site's. Not part of the test path.
//
//   build/bench/site_benchmark SIZE_M [--spacing M] [--resolution M] [--plans] [--keep FILE]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

#include "statistics.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_graph.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/planner.hpp"
#include "strata/scenes/outdoor_site.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The process's peak resident memory so far [MB].
double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

// Columns holding at least one valid surface.
std::size_t ValidColumns(const strata::TerrainModel& model) {
  const Eigen::Vector3i n = model.grid().size;
  std::size_t count = 0;
  for (int iy = 0; iy < n.y(); ++iy) {
    for (int ix = 0; ix < n.x(); ++ix) {
      const auto column = model.surfaces().Column(ix, iy);
      count += std::any_of(column.begin(), column.end(), [](const auto& s) { return s.valid; });
    }
  }
  return count;
}

// Plans from `start` to `goal` `runs` times: the median of each time [ms], the rest from the
// last result.
struct PlanFigures {
  bool ok = false;
  std::string error;
  double total_ms = 0, search_ms = 0, optimize_ms = 0, verify_ms = 0, length_m = 0;
  int expansions = 0, pieces = 0, iterations = 0, attempts = 0;
};

PlanFigures TimePlans(const strata::PlanningMap& map, const Eigen::Vector3d& start,
                      const Eigen::Vector3d& goal, int runs) {
  strata::PlanRequest request;
  request.profile = *strata::BuiltinProfile("differential");
  request.start.position_m = start;
  request.goal.position_m = goal;
  request.options.time_budget_s = 60;
  std::vector<double> totals, searches, optimizations, verifications;
  PlanFigures figures;
  for (int k = 0; k < runs; ++k) {
    const auto result = strata::Plan(map, request);
    if (!result.ok()) {
      figures.error = result.error().message;
      return figures;
    }
    totals.push_back(1e3 * result->stats.timings.total_s);
    searches.push_back(1e3 * result->stats.timings.search_s);
    optimizations.push_back(1e3 * result->stats.timings.optimize_s);
    verifications.push_back(1e3 * result->stats.timings.verify_s);
    figures.length_m = result->stats.length_m;
    figures.expansions = result->stats.search_expansions;
    figures.pieces = result->stats.pieces;
    figures.iterations = result->stats.optimizer_iterations;
    figures.attempts = result->stats.optimizer_attempts;
  }
  figures.ok = true;
  figures.total_ms = strata::bench::Median(totals);
  figures.search_ms = strata::bench::Median(searches);
  figures.optimize_ms = strata::bench::Median(optimizations);
  figures.verify_ms = strata::bench::Median(verifications);
  return figures;
}

// The site's example queries and plans of 5, 50 and 500 m (those shorter than its diagonal),
// as a table.
void PrintPlans(const strata::PlanningMap& map, double size_m) {
  const strata::OutdoorSiteLayout layout = strata::GetOutdoorSiteLayout(1, size_m);
  std::printf(
      "\n| plan | length m | expansions | pieces | L-BFGS iterations (attempts) | search / "
      "optimise "
      "/ verify ms (median) | total ms (median) |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  const Eigen::Vector3d lift(0, 0, 0.3);
  const auto row = [](const std::string& name, const PlanFigures& f) {
    if (!f.ok) {
      std::printf("| %s | failed: %s | | | | | |\n", name.c_str(), f.error.c_str());
    } else {
      std::printf("| %s | %.1f | %d | %d | %d (%d) | %.2f / %.1f / %.1f | %.2f |\n", name.c_str(),
                  f.length_m, f.expansions, f.pieces, f.iterations, f.attempts, f.search_ms,
                  f.optimize_ms, f.verify_ms, f.total_ms);
    }
  };
  for (const strata::SceneQuery& query : layout.queries) {
    row(query.name, TimePlans(map, query.start_m + lift, query.goal_m + lift, 5));
  }
  // Plans of a given straight-line length from the across_the_hills start towards its goal;
  // the goal moves on a metre at a time until it stands on ground (not on an obstacle).
  const strata::SceneQuery& diagonal = layout.queries.front();
  const Eigen::Vector2d direction = (diagonal.goal_m - diagonal.start_m).head<2>().normalized();
  for (const double distance : {5.0, 50.0, 500.0}) {
    if (distance > 0.9 * (diagonal.goal_m - diagonal.start_m).head<2>().norm()) continue;
    PlanFigures f;
    for (int k = 0; k < 20 && !f.ok; ++k) {
      const Eigen::Vector2d xy = diagonal.start_m.head<2>() + (distance + k) * direction;
      const Eigen::Vector3d goal(xy.x(), xy.y(), layout.GroundZAt(xy.x(), xy.y()));
      f = TimePlans(map, diagonal.start_m + lift, goal + lift, distance < 100 ? 20 : 5);
    }
    char name[64];
    std::snprintf(name, sizeof(name), "%.0f m along the diagonal", distance);
    row(name, f);
  }
}

// What saving a file and reading it back cost.
struct SavedFile {
  double save_s = 0;  // The save.
  double load_s = 0;  // The median of three loads.
  double mb = 0;      // Its size.
};

// Saves `path` with `save` (a Status), loads it back three times with `load` (an Expected);
// exits on a failure.
template <typename Save, typename Load>
SavedFile TimeSaveAndLoads(const std::string& path, const Save& save, const Load& load) {
  SavedFile file;
  auto start = Clock::now();
  if (const strata::Status saved = save(); !saved) {
    std::fprintf(stderr, "%s\n", saved.error().message.c_str());
    std::exit(1);
  }
  file.save_s = SecondsSince(start);
  file.mb = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::vector<double> loads;
  for (int k = 0; k < 3; ++k) {
    start = Clock::now();
    const auto loaded = load();
    loads.push_back(SecondsSince(start));
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s\n", loaded.error().message.c_str());
      std::exit(1);
    }
  }
  file.load_s = strata::bench::Median(loads);
  return file;
}

// What a map store's tiles cost (strata/io/model_tiles.hpp): cutting the model and its cloud
// into tiles (every version a store writes) and joining them (every load), medians of 3.
void PrintTiles(const strata::TerrainModel& model, double size_m, double spacing_m,
                double resolution_m) {
  const strata::PointCloud cloud = strata::GenerateOutdoorSite(1, size_m, spacing_m);
  std::vector<double> cut_model, join_model, cut_cloud, join_cloud;
  std::size_t tiles = 0;
  double model_mb = 0, cloud_mb = 0;
  for (int k = 0; k < 3; ++k) {
    auto start = Clock::now();
    const strata::TiledModel tiled = strata::CutModel(model);
    cut_model.push_back(SecondsSince(start));
    const std::vector<std::string_view> model_tiles(tiled.tiles.begin(), tiled.tiles.end());
    start = Clock::now();
    const auto joined = strata::JoinModel(tiled.header, model_tiles, "site");
    join_model.push_back(SecondsSince(start));
    start = Clock::now();
    const std::vector<std::string> cloud_tiles = strata::CutCloud(cloud, model.grid());
    cut_cloud.push_back(SecondsSince(start));
    const std::vector<std::string_view> cloud_views(cloud_tiles.begin(), cloud_tiles.end());
    start = Clock::now();
    const auto joined_cloud = strata::JoinCloud(cloud_views, "site");
    join_cloud.push_back(SecondsSince(start));
    if (!joined.ok() || !joined_cloud.ok()) {
      std::fprintf(stderr, "tiles do not join\n");
      std::exit(1);
    }
    tiles = tiled.tiles.size();
    model_mb = cloud_mb = 0;
    for (const std::string& tile : tiled.tiles) model_mb += tile.size() / 1e6;
    for (const std::string& tile : cloud_tiles) cloud_mb += tile.size() / 1e6;
  }
  std::printf(
      "\n| site | tiles | model tiles MB | cut s | join s | cloud tiles MB | cut s | join s |\n"
      "|---|---|---|---|---|---|---|---|\n"
      "| %.0f m @%.2f m, grid %.2f m | %zu | %.0f | %.3f | %.3f | %.0f | %.3f | %.3f |\n",
      size_m, spacing_m, resolution_m, tiles, model_mb, strata::bench::Median(cut_model),
      strata::bench::Median(join_model), cloud_mb, strata::bench::Median(cut_cloud),
      strata::bench::Median(join_cloud));
}

}  // namespace

int main(int argc, char** argv) {
  double size_m = 100, spacing_m = 0.1, resolution_m = 0.2;
  bool plans = false;
  std::string keep;
  CLI::App app("Site-scale assessment, memory, saved model and plan figures.", "site_benchmark");
  app.add_option("SIZE_M", size_m, "side of the outdoor_site [m]")->required();
  app.add_option("--spacing", spacing_m, "point spacing [m]")->capture_default_str();
  app.add_option("--resolution", resolution_m, "grid resolution [m]")->capture_default_str();
  app.add_flag("--plans", plans, "also time plans of a few metres and across the site");
  app.add_option("--keep", keep, "keep the saved model in FILE (default: a temporary file)");
  std::string model_file;
  app.add_option("--model", model_file,
                 "only time the plans, on FILE, a saved model of the SIZE_M site (--keep)");
  CLI11_PARSE(app, argc, argv);
  if (!model_file.empty()) {
    auto loaded = strata::LoadModel(model_file);
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s\n", loaded.error().message.c_str());
      return 1;
    }
    PrintPlans(strata::PlanningMap(*loaded), size_m);
    return 0;
  }

  auto start = Clock::now();
  strata::PointCloud cloud = strata::GenerateOutdoorSite(1, size_m, spacing_m);
  const double generate_s = SecondsSince(start);
  const std::size_t points = cloud.size();
  strata::AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  start = Clock::now();
  auto assessed = strata::TerrainModel::Assess(cloud, config);
  const double assess_s = SecondsSince(start);
  if (!assessed.ok()) {
    std::fprintf(stderr, "assessment failed: %s\n", assessed.error().message.c_str());
    return 1;
  }
  const double peak_after_assess_mb = PeakRssMb();
  cloud = {};
  cloud.shrink_to_fit();
  const strata::TerrainModel& model = **assessed;
  const std::size_t valid_columns = ValidColumns(model);
  const double model_mb = static_cast<double>(model.MemoryBytes()) / 1e6;

  strata::PlanningMap map(*assessed);
  start = Clock::now();
  auto graph = map.Graph(strata::BuiltinProfile("differential")->Traversability());
  const double graph_s = SecondsSince(start);
  if (!graph.ok()) {
    std::fprintf(stderr, "graph failed: %s\n", graph.error().message.c_str());
    return 1;
  }
  const double peak_after_graph_mb = PeakRssMb();
  const std::size_t graph_bytes = (*graph)->MemoryBytes();

  const std::string path = keep.empty() ? (std::filesystem::temp_directory_path() /
                                           ("site_benchmark_" + std::to_string(::getpid())))
                                              .string()
                                        : keep;
  const SavedFile saved_model = TimeSaveAndLoads(
      path, [&] { return strata::SaveModel(model, path); },
      [&] { return strata::LoadModel(path); });
  if (keep.empty()) std::filesystem::remove(path);
  const double save_s = saved_model.save_s, load_s = saved_model.load_s, file_mb = saved_model.mb;
  // The graph saved as a map store keeps it, and loaded back onto the model as another replica
  // does instead of building it.
  const std::string graph_path = path + ".stratagraph";
  const SavedFile saved_graph = TimeSaveAndLoads(
      graph_path, [&] { return strata::SaveGraph(**graph, graph_path); },
      [&] { return strata::LoadGraph(graph_path, model); });
  std::filesystem::remove(graph_path);
  const double graph_save_s = saved_graph.save_s, graph_load_s = saved_graph.load_s,
               graph_file_mb = saved_graph.mb;

  std::printf(
      "| site | points | grid columns | valid-ground columns | generate s | assess s | model MB "
      "| B / valid column | peak RSS MB (assessed) | graph nodes | graph s | graph MB | B / node "
      "| peak RSS MB (with graph) | saved MB | save s | load s | assess / load |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::printf(
      "| %.0f m @%.2f m, grid %.2f m | %.2f M | %.1f M | %.1f M | %.1f | %.2f | %.0f | %.0f | "
      "%.0f | %.1f M | %.2f | %.0f | %.1f | %.0f | %.0f | %.2f | %.3f | %.0f× |\n",
      size_m, spacing_m, resolution_m, points / 1e6, model.grid().LayerCellCount() / 1e6,
      valid_columns / 1e6, generate_s, assess_s, model_mb,
      static_cast<double>(model.MemoryBytes()) / static_cast<double>(valid_columns),
      peak_after_assess_mb, (*graph)->node_count() / 1e6, graph_s, graph_bytes / 1e6,
      static_cast<double>(graph_bytes) / (*graph)->node_count(), peak_after_graph_mb, file_mb,
      save_s, load_s, assess_s / load_s);

  std::printf(
      "\n| site | graph nodes | graph built s | saved graph MB | B / node | save s | load s | "
      "built / loaded |\n|---|---|---|---|---|---|---|---|\n");
  std::printf(
      "| %.0f m @%.2f m, grid %.2f m | %.1f M | %.2f | %.0f | %.1f | %.2f | %.3f | %.0f× |\n",
      size_m, spacing_m, resolution_m, (*graph)->node_count() / 1e6, graph_s, graph_file_mb,
      graph_file_mb * 1e6 / (*graph)->node_count(), graph_save_s, graph_load_s,
      graph_s / graph_load_s);

  PrintTiles(model, size_m, spacing_m, resolution_m);
  if (plans) PrintPlans(map, size_m);
  return 0;
}
