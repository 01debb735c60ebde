#include "map_build.hpp"

#include <chrono>
#include <utility>

#include "map_store.hpp"
#include "strata/saved_model.hpp"

namespace strata::server {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

Expected<LoadedCloud> LoadMapSource(MapSource source, const CloudLoadLimits& limits) {
  if (const auto* file = std::get_if<FileMapSource>(&source)) {
    return LoadPointCloud(file->ToRead(), limits);
  }
  if (auto* scene = std::get_if<SceneMapSource>(&source)) {
    return ::strata::LoadMapSource(*scene, limits);
  }
  // The points move into the sanitised cloud, whose memory the build's reservation covers.
  return SanitizeCloud(std::move(std::get<UploadMapSource>(source).points), limits);
}

Expected<BuiltMap> BuildMapHere(MapBuildJob job, const BuildMonitor& monitor,
                                const CloudLoader& loader) {
  BuiltMap built;
  const auto load_start = std::chrono::steady_clock::now();
  if (job.saved_model) {
    const FileMapSource& file = std::get<FileMapSource>(job.source);
    Expected<std::shared_ptr<const TerrainModel>> model = LoadModel(file.ToRead());
    if (!model) return model.error();
    built.model = std::move(model).value();
    built.raw_point_count = built.model->summary().input_points;
    built.load_s = SecondsSince(load_start);
    built.version = MapStore::VersionOfSavedModel(file.file->ProcPath());
    if (monitor.on_loaded) monitor.on_loaded(built.raw_point_count, 0, built.load_s);
    return built;
  }
  Expected<LoadedCloud> loaded = loader(std::move(job.source), job.limits);
  if (!loaded) return loaded.error();
  built.raw_point_count = loaded->raw_point_count;
  built.dropped_nonfinite = loaded->dropped_nonfinite;
  built.load_s = SecondsSince(load_start);
  if (monitor.on_loaded) {
    monitor.on_loaded(built.raw_point_count, built.dropped_nonfinite, built.load_s);
  }
  const AssessmentControl control{monitor.on_progress, monitor.should_stop};
  Expected<std::shared_ptr<const TerrainModel>> model =
      TerrainModel::Assess(loaded->points, job.config, control);
  if (!model) return model.error();
  built.model = std::move(model).value();
  built.version = MapStore::VersionOf(loaded->points, job.config, {});
  if (job.keep_cloud) built.cloud = std::move(loaded->points);
  return built;
}

}  // namespace strata::server
