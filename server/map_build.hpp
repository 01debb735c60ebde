#pragma once
/// Making a map: reading its source (a file, a scene or uploaded points) and assessing it, or
/// loading a saved model. The same code runs in the worker process the server starts for each
/// new map (map_worker.hpp, strata-map-worker) and, in tests, on the registry's own thread.
/// No gRPC here.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <variant>

#include "map_root.hpp"
#include "memory_budget.hpp"
#include "service_error.hpp"
#include "strata/cloud_io.hpp"
#include "strata/point_cloud.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/terrain_config.hpp"
#include "strata/terrain_model.hpp"

namespace strata::server {

/// A point-cloud file (or saved model), opened inside the map root (OpenMapFile).
struct FileMapSource {
  std::shared_ptr<const OpenedMapFile> file;  ///< What is read.
  std::string
      requested_path;  ///< As the client gave it: messages name it, its extension the format.

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

/// Everything needed to make one map.
struct MapBuildJob {
  MapSource source;
  AssessmentConfig config;  ///< Ignored for a saved model, which keeps its own.
  /// The file is a saved model (strata/saved_model.hpp): loaded, not assessed.
  bool saved_model = false;
  CloudLoadLimits limits;   ///< On reading the source.
  bool keep_cloud = false;  ///< Return the sanitised cloud too (a map store keeps it).
};

/// A map made, with the figures Map reports.
struct BuiltMap {
  std::shared_ptr<const TerrainModel> model;
  PointCloud cloud;  ///< The sanitised cloud when MapBuildJob::keep_cloud; empty otherwise.
  std::size_t raw_point_count = 0;    ///< Points the source held, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped for a NaN/Inf coordinate.
  double load_s = 0;                  ///< Reading the source [s].
  /// The version the map store names it by (MapStore::VersionOf, VersionOfSavedModel).
  std::string version;
};

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

/// Reads a source into a sanitised cloud (file, scene or upload).
using CloudLoader = std::function<Expected<LoadedCloud>(MapSource, const CloudLoadLimits&)>;

/// The loader the server uses: strata::LoadMapSource (strata/scenes/map_source.hpp, the one
/// strata-offline uses) for files and scenes, SanitizeCloud for uploads.
Expected<LoadedCloud> LoadMapSource(MapSource source, const CloudLoadLimits& limits);

/// Makes the map of `job` in this process and on this thread, reading the source with
/// `loader`. Fails as the loader, LoadModel or TerrainModel::Assess do.
Expected<BuiltMap> BuildMapHere(MapBuildJob job, const BuildMonitor& monitor,
                                const CloudLoader& loader = LoadMapSource);

}  // namespace strata::server
