// Travel-cost figures for docs/benchmarks.md ("Travel-cost matrices"): how long an N × M
// matrix takes on the shared maps with one and two threads (the searches split between them as
// strata-server splits them over its planning slots), and how the estimates compare with the
// trajectories strata::Plan returns for random reachable pairs (duration and length ratios).
// Not part of the test path.
//
//   STRATA_MAPS_DIR=../shared/maps build/bench/travel_cost_benchmark [--size 100] [--runs 7]
//       [--pairs 500] [--seed 1] [--coarse-cell M] [--maps scene20.2 spiral0.3_2]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "compare/bench_pairs.hpp"
#include "statistics.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planner.hpp"
#include "strata/travel_costs.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using strata::bench::Median;
using strata::bench::Quantile;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::unique_ptr<strata::PlanningMap> LoadMap(const std::string& path) {
  auto cloud = strata::LoadPointCloud(path, strata::CloudLoadLimits{});
  if (!cloud) {
    std::fprintf(stderr, "%s\n", cloud.error().message.c_str());
    std::exit(1);
  }
  strata::AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  return std::make_unique<strata::PlanningMap>(
      strata::TerrainModel::Assess(cloud->points, config).value());
}

struct MatrixTiming {
  double prepare_ms = 0;  // Snapping and the search graph, on one thread.
  double total_ms = 0;    // The whole matrix.
  int search_nodes = 0;
  int reachable = 0;
};

// One matrix with `threads` threads taking searches in turn, as the server does.
MatrixTiming TimeMatrix(const strata::SurfaceGraph& graph, const strata::RobotProfile& profile,
                        const std::vector<Eigen::Vector3d>& starts,
                        const std::vector<Eigen::Vector3d>& goals,
                        const strata::TravelCostConfig& config, int threads) {
  MatrixTiming timing;
  const auto t0 = Clock::now();
  auto query =
      strata::TravelCostQuery::Prepare(graph, profile, starts, goals, {}, 1.0, config).value();
  timing.prepare_ms = MsSince(t0);
  strata::TravelCostMatrix matrix = query.InitialMatrix();
  std::atomic<int> next{0};
  const auto work = [&] {
    strata::TravelCostWorkspace workspace;
    for (int k = next++; k < query.search_count(); k = next++) {
      (void)query.RunSearch(k, &workspace, &matrix);
    }
  };
  std::vector<std::thread> helpers;
  for (int t = 1; t < threads; ++t) helpers.emplace_back(work);
  work();
  for (std::thread& t : helpers) t.join();
  timing.total_ms = MsSince(t0);
  timing.search_nodes = query.search_node_count();
  for (const strata::TravelCost& cell : matrix.cells) timing.reachable += cell.reachable();
  return timing;
}

}  // namespace

int main(int argc, char** argv) {
  int size = 100, runs = 7, pairs = 500;
  unsigned seed = 1;
  strata::TravelCostConfig config;
  CLI::App app("Travel-cost matrix speed and calibration against strata::Plan");
  app.add_option("--size", size, "N = M of the timed matrix")->capture_default_str();
  app.add_option("--runs", runs, "timed runs per thread count (median)")->capture_default_str();
  app.add_option("--pairs", pairs, "calibration pairs per map (0 skips)")->capture_default_str();
  app.add_option("--seed", seed, "seed of the random ends")->capture_default_str();
  app.add_option("--coarse-cell", config.coarse_cell_m, "TravelCostConfig::coarse_cell_m [m]")
      ->capture_default_str();
  std::vector<std::string> map_names = {"scene20.2", "spiral0.3_2"};
  app.add_option("--maps", map_names, "shared maps to run on (file names without .pcd)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const char* env = std::getenv("STRATA_MAPS_DIR");
  const std::string dir = env ? env : "../shared/maps";
  const strata::RobotProfile profile = strata::BuiltinProfile("differential").value();

  std::map<std::string, std::unique_ptr<strata::PlanningMap>> maps;
  for (const std::string& name : map_names) {
    maps[name] = LoadMap(dir + "/" + name + ".pcd");
  }

  std::printf("### %d × %d matrices (median of %d; coarse_cell_m %.2f)\n\n", size, size, runs,
              config.coarse_cell_m);
  std::printf(
      "| map | graph nodes | search nodes | threads | prepare ms | total ms | reachable cells "
      "|\n|---|---|---|---|---|---|---|\n");
  for (const auto& [name, map] : maps) {
    const auto graph = map->Graph(profile.Traversability()).value();
    // Both ends drawn from the largest component, like strata-bench's pairs.
    const auto drawn = strata::bench::DrawQueryPairs(*graph, size, seed);
    std::vector<Eigen::Vector3d> starts, goals;
    for (const auto& pair : drawn) {
      starts.push_back(pair.start_m);
      goals.push_back(pair.goal_m);
    }
    for (const int threads : {1, 2}) {
      std::vector<double> prepare, total;
      MatrixTiming last;
      for (int run = 0; run < runs; ++run) {
        last = TimeMatrix(*graph, profile, starts, goals, config, threads);
        prepare.push_back(last.prepare_ms);
        total.push_back(last.total_ms);
      }
      std::printf("| %s | %d | %d | %d | %.1f | %.1f | %d |\n", name.c_str(), graph->node_count(),
                  last.search_nodes, threads, Median(prepare), Median(total), last.reachable);
      std::fflush(stdout);
    }
  }
  if (pairs <= 0) return 0;

  std::printf(
      "\n### Estimate against strata::Plan (%d random reachable pairs per map, seed %u)\n\n", pairs,
      seed);
  std::printf(
      "| map | planned | time ratio p5 / median / p95 | length ratio p5 / median / p95 | "
      "Plan duration / (length / v_max) median | estimate ms per pair median |\n"
      "|---|---|---|---|---|---|\n");
  for (const auto& [name, map] : maps) {
    const auto graph = map->Graph(profile.Traversability()).value();
    std::vector<double> time_ratio, length_ratio, plan_pace, estimate_ms;
    int planned = 0;
    for (const auto& pair : strata::bench::DrawQueryPairs(*graph, pairs, seed)) {
      strata::PlanRequest request;
      request.profile = profile;
      request.start.position_m = pair.start_m;
      request.goal.position_m = pair.goal_m;
      const auto plan = strata::Plan(*map, request);
      if (!plan) continue;  // The estimate is of the trajectories Plan returns.
      ++planned;
      const auto t0 = Clock::now();
      const std::vector<Eigen::Vector3d> start = {pair.start_m}, goal = {pair.goal_m};
      const auto matrix =
          strata::EstimateTravelCosts(*graph, profile, start, goal, {}, 1.0, config).value();
      estimate_ms.push_back(MsSince(t0));
      const strata::TravelCost& cell = matrix.at(0, 0);
      if (!cell.reachable() || plan->stats.duration_s <= 0) continue;
      time_ratio.push_back(cell.time_s / plan->stats.duration_s);
      length_ratio.push_back(cell.length_m / plan->stats.length_m);
      plan_pace.push_back(plan->stats.duration_s /
                          (plan->stats.length_m / profile.max_speed_horizontal_mps));
    }
    std::printf("| %s | %d / %d | %.3f / %.3f / %.3f | %.3f / %.3f / %.3f | %.3f | %.2f |\n",
                name.c_str(), planned, pairs, Quantile(time_ratio, 0.05), Median(time_ratio),
                Quantile(time_ratio, 0.95), Quantile(length_ratio, 0.05), Median(length_ratio),
                Quantile(length_ratio, 0.95), Median(plan_pace), Median(estimate_ms));
    std::fflush(stdout);
  }
  return 0;
}
