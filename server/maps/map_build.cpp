#include "maps/map_build.hpp"

#include "strata/common/seconds_since.hpp"

#include <chrono>
#include <limits>
#include <optional>
#include <utility>

#include "maps/map_store.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/io/tiled_edit.hpp"

namespace strata::server {
namespace {

using common::SecondsSince;

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

namespace {

// What an edit starts from.
struct BaseVersion {
  std::shared_ptr<const TerrainModel> model;
  PointCloud cloud;
};

// The version `files` holds: joined from its tiles, or read from its whole files.
Expected<BaseVersion> ReadBase(const VersionFiles& files) {
  if (files.tiles) {
    Result<std::shared_ptr<const TerrainModel>> model =
        LoadTiledModel(*files.tiles, "of the map's current version");
    if (!model) return Error{ErrorCode::kMapLoadFailed, model.error().message};
    Result<PointCloud> cloud = LoadTiledCloud(*files.tiles, "of the map's current version");
    if (!cloud) return Error{ErrorCode::kMapLoadFailed, cloud.error().message};
    return BaseVersion{std::move(model).value(), std::move(cloud).value()};
  }
  Expected<std::shared_ptr<const TerrainModel>> model =
      LoadModel(NamedFile(files.model->ProcPath(), "the map's current model"));
  if (!model) return model.error();
  // The stored cloud passed the limits when it was accepted; these only guard the reader.
  CloudLoadLimits unbounded;
  unbounded.max_points = std::numeric_limits<std::size_t>::max();
  unbounded.max_file_bytes = std::numeric_limits<std::size_t>::max();
  unbounded.max_abs_coordinate_m = std::numeric_limits<double>::max();
  Expected<LoadedCloud> cloud =
      LoadPointCloud(NamedFile(files.cloud->ProcPath(), "the map's current cloud.pcd"), unbounded);
  if (!cloud) return cloud.error();
  return BaseVersion{std::move(model).value(), std::move(cloud->points)};
}

// The next version of a tiled map, made from its tiles around the edit (EditStoredTerrain):
// its cut, and no model (the caller joins it, taking the tiles it holds from memory). Null
// when the edit needs the whole cloud.
Expected<std::optional<BuiltMap>> BuildEditFromTiles(const EditSource& edit,
                                                     const BuildMonitor& monitor) {
  const AssessmentControl control{monitor.on_progress, monitor.should_stop};
  Expected<StoredTerrainEdit> made = EditStoredTerrain(*edit.files.tiles, edit.edits, control);
  if (!made) return made.error();
  const TiledTerrainEdit& figures = made->edit;
  if (!figures.needs_whole.empty()) return std::optional<BuiltMap>();
  BuiltMap built;
  // Read with the edit: the tiles around it, not the base.
  if (monitor.on_loaded) monitor.on_loaded(figures.cloud_points, 0, 0);
  EditFigures& out = built.edit.emplace();
  out.apply_s = figures.apply_s;
  out.reassess_s = figures.reassess_s;
  out.reassessed_columns = figures.reassessed_columns;
  out.changed_columns = figures.changed_columns;
  out.scan_points_outside_region = figures.scans.outside_region;
  out.scan_points_thinned = figures.scans.thinned;
  out.cloud_points = figures.cloud_points;
  out.from_tiles = true;
  built.raw_point_count = figures.cloud_points;
  built.cut = std::move(made->cut);
  built.version = MapStore::TerrainOfTiles(built.cut->list.cloud, figures.config);
  return std::optional<BuiltMap>(std::move(built));
}

// The next version of a published map: its cloud edited, the touched terrain reassessed.
Expected<BuiltMap> BuildEditHere(const EditSource& edit, const MapBuildJob& job,
                                 const BuildMonitor& monitor) {
  if (CutsTiles(job)) {
    Expected<std::optional<BuiltMap>> from_tiles = BuildEditFromTiles(edit, monitor);
    if (!from_tiles) return from_tiles.error();
    if (*from_tiles) return std::move(**from_tiles);
  }
  BuiltMap built;
  const auto load_start = std::chrono::steady_clock::now();
  Expected<BaseVersion> base = ReadBase(edit.files);
  if (!base) return base.error();
  std::shared_ptr<const TerrainModel>& model = base->model;
  const PointCloud& cloud = base->cloud;
  built.raw_point_count = cloud.size();
  built.load_s = SecondsSince(load_start);
  if (monitor.on_loaded) monitor.on_loaded(built.raw_point_count, 0, built.load_s);
  EditFigures figures;
  const auto apply_start = std::chrono::steady_clock::now();
  ScanCounts scans;
  Expected<PointCloud> edited = ApplyEdits(cloud, edit.edits, *model, &scans);
  if (!edited) return edited.error();
  figures.apply_s = SecondsSince(apply_start);
  figures.scan_points_outside_region = scans.outside_region;
  figures.scan_points_thinned = scans.thinned;
  const auto reassess_start = std::chrono::steady_clock::now();
  const AssessmentControl control{monitor.on_progress, monitor.should_stop};
  Expected<Reassessment> reassessed =
      ReassessRegion(*model, cloud, *edited, EditBounds(edit.edits), control);
  if (!reassessed) return reassessed.error();
  figures.reassess_s = SecondsSince(reassess_start);
  figures.full_reassessment = reassessed->path == ReassessmentPath::kFull;
  figures.full_reason = reassessed->full_reason;
  figures.reassessed_columns = reassessed->reassessed_columns;
  figures.changed_columns = reassessed->changed_columns;
  figures.cloud_points = edited->size();
  built.model = std::move(reassessed->model);
  built.version = MapStore::VersionOf(*edited, built.model->config(), {});
  if (CutsTiles(job)) {
    // Outside the columns reassessed the tiles are the base's, byte for byte.
    std::optional<BaseTiles> kept;
    if (!figures.full_reassessment) {
      kept = BaseTiles{edit.files.tiles->list,
                       TilesTouching(built.model->grid(), figures.changed_columns)};
    }
    built.cut = CutIntoTiles(*built.model, *edited, kept ? &*kept : nullptr);
  } else if (job.keep_cloud) {
    built.cloud = std::move(edited).value();
  }
  built.edit = std::move(figures);
  return built;
}

// A new map's source, out of a build's that is not an edit.
MapSource NewMapSource(BuildSource source) {
  if (auto* file = std::get_if<FileMapSource>(&source)) return std::move(*file);
  if (auto* scene = std::get_if<SceneMapSource>(&source)) return std::move(*scene);
  return std::move(std::get<UploadMapSource>(source));
}

}  // namespace

bool CutsTiles(const MapBuildJob& job) {
  const auto* edit = std::get_if<EditSource>(&job.source);
  return edit != nullptr && edit->files.tiles && job.keep_cloud;
}

Expected<BuiltMap> BuildMapHere(MapBuildJob job, const BuildMonitor& monitor,
                                const CloudLoader& loader) {
  if (const auto* edit = std::get_if<EditSource>(&job.source)) {
    return BuildEditHere(*edit, job, monitor);
  }
  BuiltMap built;
  const auto load_start = std::chrono::steady_clock::now();
  if (job.saved_model) {
    const FileMapSource& file = std::get<FileMapSource>(job.source);
    Expected<std::shared_ptr<const TerrainModel>> model = LoadModel(file.ToRead());
    if (!model) return model.error();
    built.model = std::move(model).value();
    built.raw_point_count = built.model->summary().input_points;
    built.load_s = SecondsSince(load_start);
    built.version = MapStore::TerrainOfSavedModel(file.file->ProcPath());
    if (monitor.on_loaded) monitor.on_loaded(built.raw_point_count, 0, built.load_s);
    return built;
  }
  Expected<LoadedCloud> loaded = loader(NewMapSource(std::move(job.source)), job.limits);
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
