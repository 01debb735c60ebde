// Planning figures for docs/benchmarks.md: the eleven reference queries of
// ../shared/maps/README.md (median of RUNS runs each, 5 unless given) and random start/goal
// pairs on each shared map (fixed seed), each returned trajectory also checked by the
// benchmark's own check (stderr). Prints markdown tables. Not part of the test path.
//
//   STRATA_MAPS_DIR=../shared/maps build/bench/planning_benchmark [PAIRS] [SEED] [BUDGET_S] [RUNS]
//
// BUDGET_S is each plan's time budget, the product's default (PlanOptions) unless given: a
// sanitised build's smoke run gives it more, so that it checks the plans, not that build's
// speed, and plans each query once.
//
// Also: each trajectory's duration against driving its length at the speed bound, and
// replanning on the way (a state 30 m before the goal, with and without the trajectory as
// a warm start). Beside the times, the work each query took (A* expansions, L-BFGS
// iterations, MINCO pieces), which does not depend on the machine.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "compare/bench_pairs.hpp"
#include "statistics.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planner.hpp"
#include "verifier_bounds.hpp"

namespace {

using strata::PlanningMap;

struct Query {
  const char* name;
  const char* map;
  Eigen::Vector3d start, goal;
};

const Query kQueries[] = {
    {"s2_flat_diag", "scene20.2", {-6, -8, 1}, {16, 16, 1}},
    {"s2_ground_to_deck", "scene20.2", {-4, 16, 1}, {6.5, -1.5, 3.5}},
    {"s2_deck_to_ground", "scene20.2", {6.5, -2, 3.5}, {16, 8, 1}},
    {"s2_under_deck", "scene20.2", {0, -2, 1}, {13, -2, 1}},
    {"s2_around_walls", "scene20.2", {-5, -8, 1}, {15, -8, 1}},
    {"sp_ground_left", "spiral0.3_2", {-38, -2, 1.5}, {-26, -24, 1.5}},
    {"sp_ground_right", "spiral0.3_2", {-18, 0, 1.5}, {8, 2, 1.5}},
    {"sp_ground_to_l1", "spiral0.3_2", {-30, -2, 1.5}, {-45, -29, 5.5}},
    {"sp_ground_to_top", "spiral0.3_2", {-30, -2, 1.5}, {-30, -28, 21.5}},
    {"sp_top_to_ground", "spiral0.3_2", {-16, -23, 21.5}, {-18, 0, 1.5}},
    {"sp_cross_wall", "spiral0.3_2", {-30, -2, 1.5}, {-15, 0, 1.5}},
};

// The original code's plan times on these queries [ms] (../shared/maps/README.md).
const std::map<std::string, double> kOriginalMs = {
    {"s2_flat_diag", 210},     {"s2_ground_to_deck", 277}, {"s2_deck_to_ground", 311},
    {"s2_under_deck", 27},     {"s2_around_walls", 161},   {"sp_ground_left", 40},
    {"sp_ground_right", 68},   {"sp_ground_to_l1", 125},   {"sp_ground_to_top", 806},
    {"sp_top_to_ground", 159}, {"sp_cross_wall", 1224}};

using strata::bench::Median;
using strata::bench::Quantile;

std::unique_ptr<PlanningMap> LoadMap(const std::string& dir, const std::string& name,
                                     double resolution_m) {
  auto cloud = strata::LoadPointCloud(dir + "/" + name + ".pcd", strata::CloudLoadLimits{});
  if (!cloud) {
    std::fprintf(stderr, "%s\n", cloud.error().message.c_str());
    std::exit(1);
  }
  strata::AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  return std::make_unique<PlanningMap>(strata::TerrainModel::Assess(cloud->points, config).value());
}

// The maps of the random pairs: the shared maps at 0.2 m, and the spiral also at 0.3 m, the
// resolution the original code runs it at.
struct MapSetting {
  const char* label;
  const char* file;
  double resolution_m;
};
const MapSetting kPairMaps[] = {{"scene20.2 @0.2", "scene20.2", 0.2},
                                {"spiral0.3_2 @0.2", "spiral0.3_2", 0.2},
                                {"spiral0.3_2 @0.3", "spiral0.3_2", 0.3}};

// How long a trajectory takes against driving its length at the horizontal speed bound.
double DurationRatio(const strata::PlanStats& s) {
  const double v = strata::BuiltinProfile("differential")->max_speed_horizontal_mps;
  return s.length_m > 0 ? s.duration_s * v / s.length_m : 0;
}

// The time on `t` from which `remaining_m` of its path is left (0 if it is shorter).
double TimeWithRemaining(const strata::Trajectory& t, double remaining_m) {
  const double total = t.TotalDuration();
  double left = 0;
  Eigen::Vector3d previous = t.Position(total).head<3>();
  for (double time = total; time > 0; time -= 0.01) {
    const Eigen::Vector3d p = t.Position(std::max(time - 0.01, 0.0)).head<3>();
    left += (p - previous).norm();
    previous = p;
    if (left >= remaining_m) return std::max(time - 0.01, 0.0);
  }
  return 0;
}

double g_time_budget_s = strata::PlanOptions().time_budget_s;  // Set once, from BUDGET_S.

strata::PlanRequest Request(const Eigen::Vector3d& start, const Eigen::Vector3d& goal) {
  strata::PlanRequest r;
  r.options.time_budget_s = g_time_budget_s;
  r.start.position_m = start;
  r.goal.position_m = goal;
  r.profile = strata::BuiltinProfile("differential").value();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const char* env = std::getenv("STRATA_MAPS_DIR");
  const std::string dir = env ? env : "../shared/maps";
  const int pairs = argc > 1 ? std::atoi(argv[1]) : 200;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 1;
  if (argc > 3) g_time_budget_s = std::atof(argv[3]);
  const int runs = argc > 4 ? std::max(1, std::atoi(argv[4])) : 5;
  std::map<std::string, std::unique_ptr<PlanningMap>> maps;  // By label.
  for (const MapSetting& m : kPairMaps) maps[m.label] = LoadMap(dir, m.file, m.resolution_m);
  for (auto& [name, map] : maps) {  // Build the differential robot's graph before timing.
    (void)map->Graph(strata::BuiltinProfile("differential")->Traversability());
  }
  const auto at_02 = [&maps](const std::string& file) { return maps.at(file + " @0.2").get(); };

  std::printf(
      "| query | result | total ms (median of %d) | snap / search / optimise / verify ms | "
      "original ms | speed-up | length m | duration s (ratio) | κ_m 1/m | max v h/v m/s | "
      "max a h/v m/s² | expansions / iterations / pieces |\n",
      runs);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Query& q : kQueries) {
    std::vector<double> total, snap, search, optimize, verify;
    strata::Expected<strata::PlanResult> last = strata::Error{strata::ErrorCode::kNoPath, ""};
    for (int run = 0; run < runs; ++run) {
      last = strata::Plan(*at_02(q.map), Request(q.start, q.goal));
      const auto& t = last ? last->stats.timings : strata::PlanTimings{};
      if (!last) break;
      total.push_back(t.total_s * 1e3);
      snap.push_back(t.snap_s * 1e3);
      search.push_back(t.search_s * 1e3);
      optimize.push_back(t.optimize_s * 1e3);
      verify.push_back(t.verify_s * 1e3);
    }
    const double original = kOriginalMs.at(q.name);
    if (!last) {
      std::printf("| %s | %s | | | %.0f | | | | | | | |\n", q.name,
                  strata::ErrorCodeName(last.error().code), original);
      std::fprintf(stderr, "%s: %s\n", q.name, last.error().message.c_str());
      continue;
    }
    const strata::PlanStats& s = last->stats;
    std::printf(
        "| %s | %s | %.1f | %.1f / %.1f / %.1f / %.1f | %.0f | %.0f× | %.1f | %.1f (%.2f) | %.3f | "
        "%.2f / %.2f | %.2f / %.2f | %d / %d / %d |\n",
        q.name, s.fallback ? "ok (fallback)" : "ok", Median(total), Median(snap), Median(search),
        Median(optimize), Median(verify), original, original / Median(total), s.length_m,
        s.duration_s, DurationRatio(s), s.mean_curvature_per_m, s.max_speed_horizontal_mps,
        s.max_speed_vertical_mps, s.max_accel_horizontal_mps2, s.max_accel_vertical_mps2,
        s.search_expansions, s.optimizer_iterations, s.pieces);
  }

  std::printf(
      "\n| map | pairs | success | failures by reason | total ms median / p95 | "
      "search ms median / p95 | optimise ms median / p95 | length m median | "
      "κ_m median | duration ratio median / p95 | stretched / fallback | max v / a over all |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  struct Replan {
    std::vector<double> warm_ms, cold_ms;
    std::vector<double> warm_iterations, cold_iterations;
    int tried = 0, warm_started = 0;
  };
  std::map<std::string, Replan> replans;
  for (auto& [name, map] : maps) {
    const auto graph = map->Graph(strata::BuiltinProfile("differential")->Traversability()).value();
    // Valid, reachable start/goal pairs: nodes of the largest component (bench_pairs).
    const strata::bench::LargestComponent largest = strata::bench::FindLargestComponent(*graph);
    const std::vector<strata::bench::QueryPair> query_pairs =
        strata::bench::DrawQueryPairs(*graph, pairs, seed);
    std::vector<double> total, search, optimize, length, curvature, ratio;
    int stretched = 0, fallbacks = 0;
    Replan& replan = replans[name];
    double max_v = 0, max_a = 0;
    std::map<std::string, int> failures;
    int ok = 0;
    // The benchmark's own check of every returned trajectory (oracle/independent_check.hpp).
    strata::bench::IndependentCheckTally checked;
    for (const strata::bench::QueryPair& pair : query_pairs) {
      const strata::PlanRequest query = Request(pair.start_m, pair.goal_m);
      const auto plan = strata::Plan(*map, query);
      if (!plan) {
        ++failures[strata::ErrorCodeName(plan.error().code)];
        continue;
      }
      ++ok;
      checked.Add(strata::bench::CheckTrajectory(
          map->model(), query.profile, plan->trajectory,
          strata::bench::CheckConfigFor(query.options.verifier, map->keep_out())));
      const strata::PlanStats& s = plan->stats;
      total.push_back(s.timings.total_s * 1e3);
      search.push_back(s.timings.search_s * 1e3);
      optimize.push_back(s.timings.optimize_s * 1e3);
      length.push_back(s.length_m);
      curvature.push_back(s.mean_curvature_per_m);
      ratio.push_back(DurationRatio(s));
      stretched += s.time_stretch > 1;
      fallbacks += s.fallback;
      max_v = std::max(max_v, s.max_speed_horizontal_mps);
      max_a = std::max(max_a, s.max_accel_horizontal_mps2);
      // Replanning on the way with 30 m left, from the state the trajectory gives there.
      if (s.length_m < 40) continue;
      const strata::Trajectory& followed = plan->trajectory;
      const double now = TimeWithRemaining(followed, 30.0);
      strata::PlanRequest request = Request(pair.start_m, pair.goal_m);
      request.start.position_m = followed.Position(now).head<3>();
      request.start.velocity_mps = followed.Velocity(now).head<3>();
      request.start.acceleration_mps2 = followed.Acceleration(now).head<3>();
      request.goal.position_m = plan->goal.position_m;
      const auto cold = strata::Plan(*map, request);
      request.warm_start = strata::WarmStart{followed, now};
      const auto warm = strata::Plan(*map, request);
      ++replan.tried;
      if (!cold || !warm) continue;
      replan.warm_started += warm->stats.warm_started;
      replan.warm_ms.push_back(warm->stats.timings.total_s * 1e3);
      replan.cold_ms.push_back(cold->stats.timings.total_s * 1e3);
      replan.warm_iterations.push_back(warm->stats.optimizer_iterations);
      replan.cold_iterations.push_back(cold->stats.optimizer_iterations);
    }
    // An unreachable goal: a node of another component, refused from the labels.
    int island = -1;
    for (int m = 0; m < graph->node_count() && island < 0; ++m) {
      if (graph->component(m) != largest.label) island = m;
    }
    std::vector<double> refusal;
    for (int run = 0; island >= 0 && run < 5; ++run) {
      const auto begin = std::chrono::steady_clock::now();
      const auto plan =
          strata::Plan(*map, Request(graph->position(largest.nodes[0]), graph->position(island)));
      refusal.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin)
              .count());
      if (plan || plan.error().code != strata::ErrorCode::kGoalUnreachable) refusal.back() = -1;
    }
    std::fprintf(stderr, "%s: unreachable goal refused in %.3f ms (median of 5)\n", name.c_str(),
                 Median(refusal));
    std::fprintf(stderr, "%s: independent check of %s\n", name.c_str(), checked.Describe().c_str());
    std::string reasons;
    for (const auto& [reason, count] : failures)
      reasons += reason + " " + std::to_string(count) + " ";
    std::printf(
        "| %s | %d | %.2f%% | %s | %.1f / %.1f | %.1f / %.1f | %.1f / %.1f | %.1f | %.3f | "
        "%.2f / %.2f | %d / %d | %.2f / %.2f |\n",
        name.c_str(), pairs, 100.0 * ok / pairs, reasons.empty() ? "none" : reasons.c_str(),
        Median(total), Quantile(total, 0.95), Median(search), Quantile(search, 0.95),
        Median(optimize), Quantile(optimize, 0.95), Median(length), Median(curvature),
        Median(ratio), Quantile(ratio, 0.95), stretched, fallbacks, max_v, max_a);
  }

  std::printf(
      "\n| map | replans (30 m left) | warm-started | warm ms median / p95 | cold ms median / p95 "
      "| iterations warm / cold (median) |\n|---|---|---|---|---|---|\n");
  for (const auto& [name, r] : replans) {
    std::printf("| %s | %d | %d | %.2f / %.2f | %.2f / %.2f | %.0f / %.0f |\n", name.c_str(),
                r.tried, r.warm_started, Median(r.warm_ms), Quantile(r.warm_ms, 0.95),
                Median(r.cold_ms), Quantile(r.cold_ms, 0.95), Median(r.warm_iterations),
                Median(r.cold_iterations));
  }
  return 0;
}
