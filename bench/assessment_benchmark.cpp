// Terrain assessment time per stage and memory on the shared reference maps and a built-in
// scene, at several resolutions; generating outdoor_site at the sizes docs/scenes.md gives. Run
// with --benchmark_repetitions=5 (the default below) and read the median rows. Maps are looked up
// in $STRATA_MAPS_DIR (default ../shared/maps relative to the working directory).

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "strata/assessment/terrain_model.hpp"
#include "strata/scenes/map_source.hpp"

namespace {

std::string MapsDir() {
  const char* env = std::getenv("STRATA_MAPS_DIR");
  return env != nullptr ? env : "../shared/maps";
}

void BM_Load(benchmark::State& state, const strata::MapSource& source) {
  for (auto _ : state) {
    auto cloud = strata::LoadMapSource(source);
    if (!cloud) {
      state.SkipWithError(cloud.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(cloud->points.data());
  }
}

// Generating a scene alone (no sanitising copy), one core.
void BM_Generate(benchmark::State& state, const strata::SceneSource& scene) {
  for (auto _ : state) {
    auto cloud = strata::GenerateScene(scene.name, scene.seed, scene.options);
    if (!cloud) {
      state.SkipWithError(cloud.error().message.c_str());
      return;
    }
    state.counters["points"] = static_cast<double>(cloud->size());
    benchmark::DoNotOptimize(cloud->data());
  }
}

void BM_Assess(benchmark::State& state, const strata::MapSource& source, double resolution_m) {
  auto cloud = strata::LoadMapSource(source);
  if (!cloud) {
    state.SkipWithError(cloud.error().message.c_str());
    return;
  }
  strata::AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  strata::AssessmentTimings sum;
  std::size_t memory = 0;
  std::int64_t cells = 0;
  for (auto _ : state) {
    auto model = strata::TerrainModel::Assess(cloud->points, config);
    if (!model) {
      state.SkipWithError(model.error().message.c_str());
      return;
    }
    const auto& t = (*model)->summary().timings;
    sum.ground_filter_s += t.ground_filter_s;
    sum.surfaces_s += t.surfaces_s;
    sum.fields_s += t.fields_s;
    memory = (*model)->MemoryBytes();
    cells = (*model)->grid().CellCount();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["vgf_s"] = sum.ground_filter_s / n;
  state.counters["surfaces_s"] = sum.surfaces_s / n;
  state.counters["fields_s"] = sum.fields_s / n;
  state.counters["memory_MB"] = memory / 1.0e6;
  state.counters["cells"] = static_cast<double>(cells);
  state.counters["bytes_per_cell"] = static_cast<double>(memory) / static_cast<double>(cells);
}

void RegisterAll() {
  const std::string dir = MapsDir();
  const std::pair<std::string, std::string> maps[] = {
      {"scene20.2", dir + "/scene20.2.pcd"},
      {"spiral0.3_2", dir + "/spiral0.3_2.pcd"},
  };
  for (const auto& [name, path] : maps) {
    if (!std::filesystem::exists(path)) continue;
    benchmark::RegisterBenchmark(("Load/" + name).c_str(), BM_Load,
                                 strata::MapSource(strata::FileSource{path}))
        ->Unit(benchmark::kMillisecond)
        ->Repetitions(5)
        ->ReportAggregatesOnly(true);
    for (const double r : {0.1, 0.2, 0.3}) {
      benchmark::RegisterBenchmark(
          ("Assess/" + name + "/" + std::to_string(r).substr(0, 3)).c_str(), BM_Assess,
          strata::MapSource(strata::FileSource{path}), r)
          ->Unit(benchmark::kMillisecond)
          ->Repetitions(5)
          ->ReportAggregatesOnly(true)
          ->UseRealTime();
    }
  }
  // The site sizes of docs/scenes.md: side [m] and spacing [m].
  for (const auto& [size, spacing] : {std::pair{100.0, 0.1}, {400.0, 0.1}, {1000.0, 0.2}}) {
    const strata::SceneSource site{"outdoor_site", strata::kDefaultSceneSeed, {size, spacing}};
    benchmark::RegisterBenchmark(("Generate/outdoor_site/" + std::to_string(int(size)) + "/" +
                                  std::to_string(spacing).substr(0, 3))
                                     .c_str(),
                                 BM_Generate, site)
        ->Unit(benchmark::kMillisecond)
        ->Repetitions(3)
        ->ReportAggregatesOnly(true)
        ->UseRealTime();
  }
  benchmark::RegisterBenchmark("Assess/two_level_ramp/0.1", BM_Assess,
                               strata::MapSource(strata::SceneSource{"two_level_ramp"}), 0.1)
      ->Unit(benchmark::kMillisecond)
      ->Repetitions(5)
      ->ReportAggregatesOnly(true)
      ->UseRealTime();
}

}  // namespace

int main(int argc, char** argv) {
  RegisterAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
