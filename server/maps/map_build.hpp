#pragma once
/// Making a map: reading its source (a file, a scene or uploaded points) and assessing it, or
/// loading a saved model; or making the next version of a map from edits of its cloud. The
/// same code runs in the worker process the server starts for each job (map_worker.hpp,
/// strata-map-worker) and, in tests, on the registry's own threads. No gRPC here.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "common/service_error.hpp"
#include "maps/map_root.hpp"
#include "maps/map_store.hpp"
#include "maps/memory_budget.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/point_cloud.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::server {

/// A point-cloud file (or saved model), opened inside the map root (OpenMapFile).
struct FileMapSource {
  std::shared_ptr<const OpenedMapFile> file;  ///< What is read.
  /// As the client gave it: messages name it, and its extension says the format.
  std::string requested_path;

  /// The file to read, named as the client named it.
  NamedFile ToRead() const { return NamedFile(file->ProcPath(), requested_path); }
};

/// A built-in scene (strata/scenes/map_source.hpp; seed kDefaultSceneSeed unless given).
using SceneMapSource = SceneSource;

/// Uploaded points (may hold NaN/Inf: they are dropped and counted like a file's).
struct UploadMapSource {
  PointCloud points;
  std::uint64_t received_bytes = 0;
  /// The points' bytes in the server's memory budget (may be null); whoever frees the points
  /// releases it.
  std::shared_ptr<MemoryBudget::Reservation> reservation;
};

using MapSource = std::variant<FileMapSource, SceneMapSource, UploadMapSource>;

/// A published version and the edits that make the next one from it: its cloud and model,
/// opened from the store (MapStore::OpenVersion: whole files, or the tiles of its terrain).
struct EditSource {
  VersionFiles files;
  std::vector<MapEdit> edits;  ///< Applied in order (ApplyEdits).
};

/// What one build job reads: a new map's source, or a version to edit.
using BuildSource = std::variant<FileMapSource, SceneMapSource, UploadMapSource, EditSource>;

/// Everything needed to make one map.
struct MapBuildJob {
  BuildSource source;
  /// Ignored for a saved model and for an edit, which keep their own.
  AssessmentConfig config;
  /// The file is a saved model (strata/io/saved_model.hpp): loaded, not assessed.
  bool saved_model = false;
  CloudLoadLimits limits;   ///< On reading the source.
  bool keep_cloud = false;  ///< Return the sanitised cloud too (a map store keeps it).
};

/// How an edit's model was made (MapUpdateStats).
struct EditFigures {
  double apply_s = 0;                   ///< Editing the cloud [s].
  double reassess_s = 0;                ///< Reassessing the touched terrain [s].
  bool full_reassessment = false;       ///< The edits changed what the whole map depends on.
  std::string full_reason;              ///< Why, when full_reassessment.
  std::int64_t reassessed_columns = 0;  ///< Grid columns assessed again.
  std::uint64_t scan_points_outside_region = 0;  ///< Scans' points not added (ScanCounts).
  std::uint64_t scan_points_thinned = 0;         ///< Scans' points thinned away (ScanCounts).
  /// Outside these columns the model is the base's (Reassessment::changed_columns).
  CellBox changed_columns;
  std::uint64_t cloud_points = 0;  ///< Points of the edited cloud, the version's source.
  /// Made from the tiles around the edit (EditStoredTerrain), not the whole cloud and model.
  bool from_tiles = false;
  /// Joining the new model from the changed tiles and the base's held here [s] (0 when the
  /// job made the model whole).
  double join_s = 0;
};

/// A map made, with the figures Map reports.
struct BuiltMap {
  /// Null for an edit made from tiles (EditFigures::from_tiles): its `cut` and the base's
  /// tiles make the model (LoadTiledModel).
  std::shared_ptr<const TerrainModel> model;
  /// The sanitised cloud when MapBuildJob::keep_cloud and there is no `cut`; empty otherwise.
  PointCloud cloud;
  /// For an edit of a tiled version with MapBuildJob::keep_cloud: the new terrain (model and
  /// edited cloud) cut into tiles, only those the edit may have changed cut and held, the
  /// others named as the base's (CutIntoTiles with BaseTiles). What the store writes; a map
  /// worker hands back these tiles instead of the whole model and cloud.
  std::optional<CutTerrain> cut;
  std::size_t raw_point_count = 0;    ///< Points the source held, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped for a NaN/Inf coordinate.
  double load_s = 0;                  ///< Reading the source [s].
  /// The version the map store names it by with no keep-out zones, which is also the name of
  /// its terrain (MapStore::TerrainOf, TerrainOfSavedModel).
  std::string version;
  /// For an edit: how its model was made.
  std::optional<EditFigures> edit;
};

/// Whether `job` is an edit of a tiled version whose terrain is kept: its BuiltMap holds a
/// `cut` instead of a cloud (and a map worker hands back those tiles, not whole files).
bool CutsTiles(const MapBuildJob& job);

/// What a build reports as it goes, and how it is stopped. Every callable may be empty.
struct BuildMonitor {
  /// The source is read (a saved model: loaded): its point counts and the time it took.
  std::function<void(std::size_t raw_points, std::size_t dropped_nonfinite, double load_s)>
      on_loaded;
  /// The assessment's step and the fraction of it done, in [0, 1].
  std::function<void(AssessmentStage step, double fraction)> on_progress;
  /// Returning true stops the build within a unit of work: it fails with kCancelled.
  std::function<bool()> should_stop;
};

/// Makes the map of `job`, or fails as reading the source or the assessment does (or, for a
/// builder in another process, as that process does: map_worker.hpp).
using MapBuilder = std::function<Result<BuiltMap>(MapBuildJob job, const BuildMonitor& monitor)>;

/// Reads a new map's source into a sanitised cloud (file, scene or upload).
using CloudLoader = std::function<Expected<LoadedCloud>(MapSource, const CloudLoadLimits&)>;

/// The loader the server uses: strata::LoadMapSource (strata/scenes/map_source.hpp, the one
/// strata-offline uses) for files and scenes, SanitizeCloud for uploads.
Expected<LoadedCloud> LoadMapSource(MapSource source, const CloudLoadLimits& limits);

/// Makes the map of `job` in this process and on this thread, reading a new map's source with
/// `loader`. Fails as the loader, LoadModel or TerrainModel::Assess do; an edit as LoadModel,
/// LoadPointCloud, ApplyEdits or ReassessRegion do (kCancelled when monitor.should_stop asks).
Expected<BuiltMap> BuildMapHere(MapBuildJob job, const BuildMonitor& monitor,
                                const CloudLoader& loader = LoadMapSource);

}  // namespace strata::server
