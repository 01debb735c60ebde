// The cost of a map edit for docs/benchmarks.md ("Map edits"): a 2 × 2 m obstacle and a
// 5 × 5 m removal on the spiral (the shared map, $STRATA_MAPS_DIR, default ../shared/maps) and
// on the 400 m outdoor_site, timing ApplyEdits and ReassessRegion separately (median of
// --runs), against a full assessment of the edited cloud, whose model the reassessed one must
// equal byte for byte (timings aside). Not part of the test path.
//
//   build/bench/edit_benchmark [--runs N] [--spiral-resolution M] [--site-size M]
//                              [--site-model FILE] [--no-site]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "statistics.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/outdoor_site.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string MapsDir() {
  const char* env = std::getenv("STRATA_MAPS_DIR");
  return env != nullptr ? env : "../shared/maps";
}

std::string BytesWithoutTimings(const strata::TerrainModel& model) {
  strata::AssessmentSummary summary = model.summary();
  summary.timings = {};
  auto copy =
      strata::TerrainModel::FromParts(model.config(), summary, model.surfaces(), model.fields());
  return copy.ok() ? strata::SerializeModel(**copy) : std::string();
}

strata::MapEdit Box(strata::MapEdit::Kind kind, const Eigen::Vector3d& lo,
                    const Eigen::Vector3d& hi) {
  return {kind, strata::BoxPrism(Eigen::AlignedBox3d(lo, hi)), nullptr};
}

// Times one edit on `base` (assessed from `cloud`) and prints its table row.
bool TimeEdit(const std::string& map_name, const std::string& edit_name,
              const strata::PointCloud& cloud, const strata::TerrainModel& base,
              const strata::MapEdit& edit, int runs, bool check) {
  const std::vector<strata::MapEdit> edits = {edit};
  std::vector<double> apply_ms, reassess_ms, filter_ms, surfaces_ms, fields_ms;
  strata::PointCloud edited;
  strata::Reassessment reassessed;
  for (int k = 0; k < runs; ++k) {
    auto start = Clock::now();
    auto applied = strata::ApplyEdits(cloud, edits, base);
    apply_ms.push_back(MillisecondsSince(start));
    if (!applied.ok()) {
      std::fprintf(stderr, "%s: %s\n", edit_name.c_str(), applied.error().message.c_str());
      return false;
    }
    edited = std::move(applied).value();
    start = Clock::now();
    auto result = strata::ReassessRegion(base, cloud, edited, strata::EditBounds(edits));
    reassess_ms.push_back(MillisecondsSince(start));
    if (!result.ok()) {
      std::fprintf(stderr, "%s: %s\n", edit_name.c_str(), result.error().message.c_str());
      return false;
    }
    reassessed = std::move(result).value();
    const strata::AssessmentTimings& t = reassessed.model->summary().timings;
    filter_ms.push_back(1e3 * t.ground_filter_s);
    surfaces_ms.push_back(1e3 * t.surfaces_s);
    fields_ms.push_back(1e3 * t.fields_s);
  }
  double assess_ms = 0;
  bool identical = true;
  if (check) {
    const auto start = Clock::now();
    auto fresh = strata::TerrainModel::Assess(edited, base.config());
    assess_ms = MillisecondsSince(start);
    if (!fresh.ok()) {
      std::fprintf(stderr, "%s: %s\n", edit_name.c_str(), fresh.error().message.c_str());
      return false;
    }
    identical = BytesWithoutTimings(*reassessed.model) == BytesWithoutTimings(**fresh);
  }
  using strata::bench::Median;
  std::printf(
      "| %s | %s | %+lld | %s | %.1f k | %.1f | %.1f | %.1f / %.1f / %.1f | %.1f | %.0f | %.0f× | "
      "%s |\n",
      map_name.c_str(), edit_name.c_str(),
      static_cast<long long>(edited.size()) - static_cast<long long>(cloud.size()),
      strata::ReassessmentPathName(reassessed.path), reassessed.reassessed_columns / 1e3,
      Median(apply_ms), Median(reassess_ms), Median(filter_ms), Median(surfaces_ms),
      Median(fields_ms), Median(apply_ms) + Median(reassess_ms), assess_ms,
      assess_ms / (Median(apply_ms) + Median(reassess_ms)),
      !check      ? "not checked"
      : identical ? "yes"
                  : "NO");
  return identical && reassessed.path == strata::ReassessmentPath::kLocal;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  double spiral_resolution_m = 0.1, site_size_m = 400;
  std::string site_model;
  bool no_site = false;
  bool no_check = false;
  CLI::App app("Cost of a map edit: ApplyEdits and ReassessRegion against a full assessment.",
               "edit_benchmark");
  app.add_option("--runs", runs, "repetitions of each edit (median)")->capture_default_str();
  app.add_option("--spiral-resolution", spiral_resolution_m, "grid resolution on the spiral [m]")
      ->capture_default_str();
  app.add_option("--site-size", site_size_m, "side of the outdoor_site [m]")->capture_default_str();
  app.add_option("--site-model", site_model,
                 "a saved model of that site (spacing 0.1 m, grid 0.2 m) instead of assessing it");
  app.add_flag("--no-site", no_site, "the spiral only");
  app.add_flag("--no-check", no_check,
               "skip the full assessment of the edited cloud and the comparison (profiling)");
  CLI11_PARSE(app, argc, argv);

  std::printf(
      "| map | edit | points added (or removed) | path | columns reassessed | ApplyEdits ms | "
      "ReassessRegion ms | of which filter / surfaces / fields ms | edit total ms | full "
      "assessment ms | full / edit | identical to full |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool ok = true;
  {
    auto loaded = strata::LoadMapSource(strata::FileSource{MapsDir() + "/spiral0.3_2.pcd"});
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s\n", loaded.error().message.c_str());
      return 1;
    }
    strata::AssessmentConfig config;
    config.grid.resolution_m = spiral_resolution_m;
    auto base = strata::TerrainModel::Assess(loaded->points, config);
    if (!base.ok()) {
      std::fprintf(stderr, "%s\n", base.error().message.c_str());
      return 1;
    }
    char name[64];
    std::snprintf(name, sizeof(name), "spiral @%.2f m", spiral_resolution_m);
    using Kind = strata::MapEdit::Kind;
    // On the ground floor west of the dividing wall (maps README: floor at z ≈ 0), near the
    // sp_ground_to_top start; the hole cuts the floor beside it.
    ok &= TimeEdit(name, "obstacle 2 × 2 × 1.5 m", loaded->points, **base,
                   Box(Kind::kAddObstacle, {-32, -4, -0.5}, {-30, -2, 1.5}), runs, !no_check);
    ok &= TimeEdit(name, "removal 5 × 5 m", loaded->points, **base,
                   Box(Kind::kRemovePoints, {-40, -5, -1}, {-35, 0, 3}), runs, !no_check);
  }
  if (!no_site) {
    auto loaded = strata::LoadMapSource(
        strata::SceneSource{"outdoor_site", 1, strata::SceneOptions{site_size_m, 0.1}});
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s\n", loaded.error().message.c_str());
      return 1;
    }
    std::shared_ptr<const strata::TerrainModel> base;
    if (!site_model.empty()) {
      auto model = strata::LoadModel(site_model);
      if (!model.ok() || (*model)->summary().input_points != loaded->points.size()) {
        std::fprintf(stderr, "%s is not a model of this site\n", site_model.c_str());
        return 1;
      }
      base = *model;
    } else {
      strata::AssessmentConfig config;
      config.grid.resolution_m = 0.2;
      auto model = strata::TerrainModel::Assess(loaded->points, config);
      if (!model.ok()) {
        std::fprintf(stderr, "%s\n", model.error().message.c_str());
        return 1;
      }
      base = *model;
    }
    const strata::OutdoorSiteLayout layout = strata::GetOutdoorSiteLayout(1, site_size_m);
    // Beside the across_the_hills start, on open ground.
    const Eigen::Vector3d start = layout.queries.front().start_m;
    const auto ground = [&](double x, double y) { return layout.GroundZAt(x, y); };
    char name[64];
    std::snprintf(name, sizeof(name), "outdoor_site %.0f m @%.2f m", site_size_m,
                  base->grid().resolution_m);
    using Kind = strata::MapEdit::Kind;
    const double x = start.x() + 5, y = start.y() + 5;
    ok &= TimeEdit(
        name, "obstacle 2 × 2 × 1.5 m", loaded->points, *base,
        Box(Kind::kAddObstacle, {x, y, ground(x, y) - 0.5}, {x + 2, y + 2, ground(x, y) + 1.5}),
        runs, !no_check);
    ok &= TimeEdit(name, "removal 5 × 5 m", loaded->points, *base,
                   Box(Kind::kRemovePoints, {x - 10, y, ground(x - 10, y) - 3},
                       {x - 5, y + 5, ground(x - 10, y) + 3}),
                   runs, !no_check);
  }
  return ok ? 0 : 1;
}
