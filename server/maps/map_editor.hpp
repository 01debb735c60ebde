#pragma once
/// Makes new versions of published maps from edits (UpdateMap). Edits of the cloud run where
/// new maps are made: as a job of the assessment queue, in a worker process, under the same
/// limits (--max-concurrent-assessments, --max-assessment-time-s, --max-assessment-memory), and
/// they stop when the call's deadline passes or its client cancels. Keep-out zones alone
/// change no terrain: their version names the base's terrain, holds the base's graphs and is
/// written on the calling thread (its description only). A version is published
/// only when it is whole and the call still waits for it, so a call that ends early leaves the
/// map at its old version. Without a base version, an edit that another one overtook is made
/// again on the new current version.
///
/// Edits of the cloud without a base version are made in batches (a group commit): those that
/// arrive while an edit of the same map is being made wait, and are then made together, in
/// their order of arrival, into one version. So robots sending scans faster than a version is
/// made cost one job per version, not one each (and no job redone for each lost race). An edit
/// whose call ends while it waits is dropped; once its batch is being made it lands with the
/// batch (a scan lands twice alike). A batch that an edit of it makes invalid is made again
/// edit by edit, so only that edit fails. No gRPC here.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/call_control.hpp"
#include "common/free_memory.hpp"
#include "common/service_error.hpp"
#include "maps/assessment_queue.hpp"
#include "maps/map_build.hpp"
#include "maps/map_snapshot.hpp"
#include "maps/memory_budget.hpp"
#include "maps/published_maps.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/prism.hpp"

namespace strata::server {

/// One UpdateMap request, in the planner's types.
struct MapEditRequest {
  std::string id;
  std::string base_version;     ///< Empty: whatever version is current.
  std::vector<MapEdit> edits;   ///< Of the cloud, in order.
  bool clear_keep_out = false;  ///< Remove the map's keep-out zones first.
  std::vector<Prism> add_keep_out;
};

/// A new version made by MapEditor::Update, and what it cost.
struct MapUpdate {
  MapSnapshot map;
  EditFigures edit;    ///< How the model was made (zero for keep-out zones alone).
  double load_s = 0;   ///< Reading the base version's cloud and model for the edits [s].
  double write_s = 0;  ///< Writing and publishing the version once its graphs are made [s].
  /// Building the graphs of the robots that planned on the base version here, before the new
  /// one is published [s].
  double graphs_s = 0;
  TileWrites writes;  ///< The terrain's tiles written and shared (none for zones alone).
  /// What the version allocated beyond the one it was made from: the model's chunks and the
  /// graphs they do not share (MapSnapshot::memory_bytes counts them all) [bytes].
  std::size_t new_bytes = 0;
  double total_s = 0;      ///< All of it, waiting for a slot and loading the base included [s].
  int merged_updates = 1;  ///< Update calls whose edits the version holds, this one included.
};

/// What an editor uses; every pointer must outlive it.
struct MapEditorOptions {
  PublishedMaps* published = nullptr;
  AssessmentQueue* queue = nullptr;
  /// How a job is made (RegistryOptions::build).
  MapBuilder build;
  /// The planning map of a model, with its keep-out zones.
  PlanningMaker make_planning;
  /// Set aside in `memory_budget` (may be null) while a version is made [bytes].
  std::shared_ptr<MemoryBudget> memory_budget;
  std::uint64_t assessment_memory_bytes = 0;
  /// Longest one job may run once started [s], >= 0; 0: no limit.
  double max_assessment_time_s = 0;
  /// Versions kept per map [-], >= 1 (for the snapshot's list).
  int versions_kept = 5;
  /// True once the server shuts down: a job running stops.
  std::function<bool()> stopping;
  /// Asked to give freed memory back after each edit of the cloud (may be null).
  FreeMemoryReturner::Room* free_memory = nullptr;
};

class MapEditor {
 public:
  explicit MapEditor(MapEditorOptions options) : options_(std::move(options)) {}

  /// Makes and publishes the next version of `request.id`. Fails with kMapStoreRequired (no
  /// store: versions keep no clouds), kMapNotFound, kMapChanged (the base version is not the
  /// current one, or a few attempts without one were all overtaken), kEditNeedsCloud (a map
  /// made from a saved model), kInvalidInput naming the edit field, kDeadlineExceeded or
  /// kCancelled (the call ended first: nothing was published), kShuttingDown, as a worker's
  /// job fails (map_worker.hpp), or as the store does.
  Result<MapUpdate> Update(const MapEditRequest& request, const CallControl& call);

  /// Update calls on map `id` waiting for the batch being made to finish (for tests and
  /// metrics).
  int EditsWaiting(const std::string& id) const;

 private:
  struct Waiting;  // One Update call in a map's batches.
  struct Batches {
    std::deque<Waiting*> waiting;  // In their order of arrival.
    bool making = false;           // A batch of this map is being made.
  };

  // Update of an edit without a base version: in the next batch of its map.
  Result<MapUpdate> UpdateInBatch(const MapEditRequest& request, const CallControl& call);
  // Makes `batch` into one version (or edit by edit) and gives each its result.
  void MakeBatch(const std::vector<Waiting*>& batch);
  // UpdateOnce, made again on the new current version when another edit overtook it (without
  // a base version).
  Result<MapUpdate> UpdateRetrying(const MapEditRequest& request, const CallControl& call);
  Result<MapUpdate> UpdateOnce(const MapEditRequest& request, const CallControl& call);
  // Runs the edit job for `current` of `id` on the queue and waits for it within `call`.
  Result<BuiltMap> RunEditJob(const MapEditRequest& request, const std::string& current,
                              const CallControl& call);

  MapEditorOptions options_;
  mutable std::mutex batches_mutex_;
  std::condition_variable batches_changed_;
  std::map<std::string, Batches> batches_;  // Maps with an edit waiting or being made.
};

}  // namespace strata::server
