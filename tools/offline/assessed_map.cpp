#include "offline/assessed_map.hpp"

#include "strata/common/seconds_since.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>

#include "strata/io/saved_model.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::offline {
namespace {

using common::SecondsSince;

Expected<AssessedMap> LoadSaved(const std::string& path, const AssessmentConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  Expected<std::shared_ptr<const TerrainModel>> model = LoadModel(path);
  if (!model) return model.error();
  const AssessmentConfig& saved = (*model)->config();
  if (FirstDifference(config, AssessmentConfig{}).has_value()) {
    if (Status same = CheckSavedModelParameters(config, saved, path); !same) return same.error();
  }
  AssessedMap map;
  map.load_s = SecondsSince(start);
  map.raw_point_count = (*model)->summary().input_points;
  map.model = std::move(model).value();
  map.from_saved_model = true;
  return map;
}

}  // namespace

Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config,
                                    const AssessmentControl& control) {
  const auto start = std::chrono::steady_clock::now();
  Expected<MapSource> parsed = ParseMapSource(source);
  if (!parsed) return parsed.error();
  if (const auto* file = std::get_if<FileSource>(&*parsed); file && IsSavedModelFile(file->path)) {
    return LoadSaved(file->path, config);
  }
  Expected<LoadedCloud> cloud = LoadMapSource(*parsed);
  if (!cloud) return cloud.error();
  AssessedMap map;
  map.load_s = SecondsSince(start);
  map.raw_point_count = cloud->raw_point_count;
  map.dropped_nonfinite = cloud->dropped_nonfinite;
  auto model = TerrainModel::Assess(cloud->points, config, control);
  if (!model) return model.error();
  map.model = std::move(model).value();
  return map;
}

AssessmentControl ProgressLine(bool enabled) {
  AssessmentControl control;
  if (!enabled) return control;
  const bool terminal = isatty(STDERR_FILENO) != 0;
  // Called from one thread at a time (AssessmentControl); the state is the last line shown.
  auto last_stage = std::make_shared<int>(-1);
  auto last_quarter = std::make_shared<int>(-1);
  control.on_progress = [terminal, last_stage, last_quarter](AssessmentStage stage,
                                                             double fraction) {
    const int percent = static_cast<int>(100 * fraction);
    if (terminal) {
      std::fprintf(stderr, "\rstrata-offline: assessing, %-13s %3d%%", AssessmentStageName(stage),
                   percent);
      if (stage == AssessmentStage::kFields && fraction >= 1) std::fputc('\n', stderr);
      return;
    }
    const int quarter = static_cast<int>(4 * fraction);
    if (static_cast<int>(stage) == *last_stage && quarter == *last_quarter) return;
    *last_stage = static_cast<int>(stage);
    *last_quarter = quarter;
    std::fprintf(stderr, "strata-offline: assessing, %s %d%%\n", AssessmentStageName(stage),
                 25 * quarter);
  };
  return control;
}

}  // namespace strata::offline
