#pragma once
/// How strata-server and strata-map-worker talk (map_worker.hpp): the worker's command line,
/// which describes one job; the lines it writes on its standard output as the job goes; the
/// files it leaves in the job's directory; and its exit codes. Both programs use these
/// functions, so the two sides cannot drift apart. No gRPC here.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "maps/map_build.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/status.hpp"

namespace strata::server {

/// One job of a worker: what to read and how to assess it, where to write the result, and the
/// limits the worker sets on itself before it reads anything.
struct WorkerJob {
  enum class Source {
    /// A point-cloud file (or a saved model with `saved_model`), open on kWorkerSourceFd;
    /// `source` is its name as the client gave it (messages, and the format by extension).
    kFile,
    kScene,   ///< `source` is "scene:NAME:SEED[...]" (strata/scenes/map_source.hpp).
    kPoints,  ///< `source` is a binary PCD of uploaded points the server wrote.
    /// The next version of a published map: `source` is a file the server wrote holding the
    /// edits (FormatEdits); the version's cloud is open on kWorkerSourceFd, its model on
    /// kWorkerBaseModelFd, or with `tiled` the map's tiles directory on kWorkerSourceFd and
    /// the terrain's list of them in kWorkerTilesFile.
    kEdit,
  };
  Source kind = Source::kFile;
  std::string source;
  bool saved_model = false;  ///< The file is a saved model: loaded, not assessed.
  bool keep_cloud = false;   ///< Also write the sanitised cloud (kWorkerCloudFile).
  bool tiled = false;        ///< A kEdit job of a tiled terrain (see kEdit).
  AssessmentConfig config;   ///< Every field (ForEachField), num_threads included.
  CloudLoadLimits limits;
  std::filesystem::path out_dir;  ///< Where the result files go; exists.
  /// Memory the worker may allocate beyond what it holds at start [bytes]; 0: no limit.
  std::uint64_t memory_bytes = 0;
  /// CPU time the worker may use, all threads together [s]; 0: no limit.
  double cpu_s = 0;
};

/// The command-line arguments (after the program name) that describe `job`.
std::vector<std::string> WorkerArguments(const WorkerJob& job);

/// The job `argv` (from the program name on) describes; kInvalidInput naming the problem.
Expected<WorkerJob> ParseWorkerArguments(int argc, const char* const* argv);

/// The descriptor a kFile job's file (a kEdit job's cloud, or its tiles' directory) is open on
/// in the worker: the server opened and checked it (OpenMapFile, MapStore::OpenVersion), and
/// the worker reads that same file, never a path.
inline constexpr int kWorkerSourceFd = 3;
/// The descriptor a kEdit job's base model is open on in the worker.
inline constexpr int kWorkerBaseModelFd = 4;

/// The edits of a kEdit job as the contents of its edits file, one per line: the kind
/// (add_obstacle, remove_points, or scan followed by its number of points), z_min_m, z_max_m,
/// then the polygon's corners x y ..., every number in its shortest form that reads back
/// exactly. A scan's line is followed by its points, packed as in UpdateMap
/// (common/packed_points.hpp: little-endian float32 x, y, z, 12 bytes each), so they travel
/// bit for bit; the next edit's line starts after them.
std::string FormatEdits(std::span<const MapEdit> edits);
/// The edits `contents` holds (FormatEdits); kInvalidInput naming the line at fault (a scan
/// whose points the file does not hold whole is one).
Expected<std::vector<MapEdit>> ParseEdits(std::string_view contents);

/// Files in the job's out_dir.
inline constexpr const char* kWorkerModelFile = "model.smd";  ///< The saved model made.
inline constexpr const char* kWorkerCloudFile = "cloud.pcd";  ///< With keep_cloud.
/// A tiled kEdit job's result instead of those two (BuiltMap::cut): a directory holding the
/// new terrain's list of tiles (kWorkerTilesFile) and the tiles the edit cut, each in a file
/// named by its name. The server joins the model from these and its store's tiles.
inline constexpr const char* kWorkerCutDir = "cut";
/// Uploaded points, written by the server for a kPoints job (a binary PCD).
inline constexpr const char* kWorkerUploadFile = "upload.pcd";
/// The edits of a kEdit job (FormatEdits), written by the server: text lines, with a scan's
/// points in binary after its line.
inline constexpr const char* kWorkerEditsFile = "edits";
/// The list of a tiled kEdit job's tiles (TerrainTiles::Format), written by the server.
inline constexpr const char* kWorkerTilesFile = "tiles";

/// Writes `cut` into the directory `dir` (created) as kWorkerCutDir holds it.
Status WriteCutTerrain(const CutTerrain& cut, const std::filesystem::path& dir);
/// The cut the directory `dir` holds (WriteCutTerrain): its list, and every tile it holds of
/// those listed, each checked against its name. kMapLoadFailed naming what is missing or wrong.
Expected<CutTerrain> ReadCutTerrain(const std::filesystem::path& dir);

/// The worker's exit codes. Any other end (a signal) is a crash or a limit.
enum WorkerExit : int {
  kWorkerExitDone = 0,         ///< The result files are written; a kDone line was sent.
  kWorkerExitFailed = 1,       ///< A kFailed line says why.
  kWorkerExitUsage = 2,        ///< The command line is wrong (a bug of the caller).
  kWorkerExitOutOfMemory = 3,  ///< An allocation failed: the memory limit was reached.
};

/// One line of the worker's standard output.
struct WorkerReport {
  enum class Kind {
    kLoaded,    ///< The source is read: raw_points, dropped_nonfinite, load_s.
    kProgress,  ///< The assessment is at `step`, `fraction` of it done.
    kFailed,    ///< The job failed with `error`.
    kDone,      ///< The result files are written; the map is `version` (and, for an edit, `edit`).
  };
  Kind kind = Kind::kDone;
  std::size_t raw_points = 0;
  std::size_t dropped_nonfinite = 0;
  double load_s = 0;
  AssessmentStage step = AssessmentStage::kSorting;
  double fraction = 0;
  Error error{ErrorCode::kMapLoadFailed, {}};
  std::string version;              ///< BuiltMap::version, one word.
  std::optional<EditFigures> edit;  ///< BuiltMap::edit.
};

/// The line (with its newline) that ParseWorkerReport reads back as `report`.
std::string FormatWorkerReport(const WorkerReport& report);

/// The report on one line (without its newline), or nothing for a line that is not one.
std::optional<WorkerReport> ParseWorkerReport(std::string_view line);

}  // namespace strata::server
