#pragma once
/// What the server knows of one map, as every part of the server passes it around: its state,
/// where it came from, what it was assessed with, its figures and versions (MapSnapshot), and
/// the planning map of an ACTIVE version (ActiveMap). No gRPC here.
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "common/service_error.hpp"
#include "maps/map_build.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/planner.hpp"
#include "strata/prism.hpp"

namespace strata::server {

enum class MapState { kCreating, kActive, kFailed };

/// Where a CREATING map is.
enum class CreationStage { kQueued, kLoading, kAssessing, kDone };

/// What remains known of a source once it is read: a file's path as the client gave it (the
/// file itself is closed), a scene, or an upload's size.
struct FileSourceInfo {
  std::string requested_path;
};
struct UploadSummary {
  std::uint64_t received_bytes = 0;
};
using MapSourceInfo = std::variant<FileSourceInfo, SceneMapSource, UploadSummary>;

/// A consistent copy of a map's public state.
struct MapSnapshot {
  std::string id;
  MapState state = MapState::kCreating;
  CreationStage stage = CreationStage::kQueued;
  std::optional<ServiceError> failure;  ///< Set when FAILED.
  MapSourceInfo source;
  AssessmentConfig config;          ///< Parameters it is (being) assessed with.
  std::size_t raw_point_count = 0;  ///< Known after loading.
  std::size_t dropped_nonfinite_point_count = 0;
  double load_s = 0;
  /// While ASSESSING: the assessment's step under way and the fraction of it done.
  AssessmentStage assessment_step = AssessmentStage::kSorting;
  double assessment_step_fraction = 0;
  /// The file is a saved model (strata/io/saved_model.hpp): loaded, not assessed.
  bool from_saved_model = false;
  /// The rest is set once ACTIVE.
  AssessmentSummary summary;
  GridGeometry grid;
  std::size_t memory_bytes = 0;  ///< Model plus cached graphs.
  int max_levels = 0;            ///< Most valid surfaces in one column.
  std::chrono::system_clock::time_point create_time;
  std::optional<std::chrono::system_clock::time_point> done_time;
  /// Once ACTIVE: the version (MapStore::VersionOf) and the versions kept, newest first.
  std::string version;
  std::vector<std::string> versions;
  /// The map's keep-out zones (part of its version; UpdateMap sets them).
  std::vector<Prism> keep_out;

  /// Progress in [0, 1] from the stage and, while assessing, the assessment's step and its
  /// fraction done (see the proto's Map.progress).
  double progress() const;
};

/// A planning map and the version it is.
struct ActiveMap {
  std::shared_ptr<const PlanningMap> map;
  std::string version;
};

}  // namespace strata::server
