#pragma once
/// The maps a server hosts, under one id space: the maps being made here (CREATING, and FAILED
/// until replaced or deleted) and the published ones (published_maps.hpp: in this process's
/// memory, or in the map store shared by every replica, loaded on demand into a cache within
/// the server's memory budget). A new map is made by a job of the assessment queue
/// (assessment_queue.hpp), in a worker process of its own (RegistryOptions::build,
/// map_worker.hpp), then published; an edit makes the next version under the same queue and
/// limits (map_editor.hpp). No gRPC here, so it is tested on its own (and under
/// ThreadSanitizer, which Debian's gRPC cannot be: scripts/test.sh runs that build in CI).
///
/// Concurrency: one mutex guards the table of maps being made and every entry's mutable
/// fields; it is held only for bookkeeping, never while loading, assessing or planning. A
/// plan copies the map's shared_ptr<const PlanningMap> (GetActive) and lets go of every lock,
/// so creating or deleting maps never blocks planning on others, and a deleted map lives on
/// until the last plan running on it lets go. A published version never changes; UpdateMap
/// makes another. With a store every request reads the map's head there, so a map deleted or
/// updated on another replica is refused or planned on its new version at once.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "common/call_control.hpp"
#include "common/free_memory.hpp"
#include "common/service_error.hpp"
#include "maps/assessment_queue.hpp"
#include "maps/graph_writer.hpp"
#include "maps/map_build.hpp"
#include "maps/map_editor.hpp"
#include "maps/map_snapshot.hpp"
#include "maps/map_store.hpp"
#include "maps/memory_budget.hpp"
#include "maps/published_maps.hpp"
#include "maps/stored_graphs.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planner.hpp"
#include "strata/point_cloud.hpp"
#include "strata/prism.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::server {

/// Limits and resources of a registry.
struct RegistryOptions {
  /// Maps made at the same time [-], >= 1.
  int max_concurrent_assessments = 1;
  /// Maps held at once, in any state [-], >= 1.
  int max_maps = 16;
  /// Threads of one assessment's parallel stages [-], >= 0; 0 uses every core.
  int assessment_threads = 0;
  /// Limits on file loading and uploads (points, bytes, coordinates).
  CloudLoadLimits load_limits;
  /// How a map (or an edited version) is made: in a worker process (map_worker.hpp; what the
  /// server does). Empty: on the queue's own thread with `loader` (BuildMapHere).
  MapBuilder build;
  /// How sources are read when `build` is empty (tests substitute one that waits on a latch).
  CloudLoader loader = LoadMapSource;
  /// Longest the making of one map or version may take once started, reading its source
  /// included [s], >= 0; past it the job fails with kDeadlineExceeded (a worker process is
  /// killed at once, an assessment here stops within a unit of work). 0: no limit.
  double max_assessment_time_s = 0;
  /// The map store shared with other replicas; null keeps maps in this registry only.
  std::shared_ptr<MapStore> store;
  /// The server's memory budget (memory_budget.hpp); null: none. The registry counts its maps
  /// there, lets a store's maps go when room is needed, sets assessment_memory_bytes aside
  /// for each map being made or edited, and admits a map made only when it fits.
  std::shared_ptr<MemoryBudget> memory_budget;
  /// Gives the memory versions freed back to the system (free_memory.hpp). One per process,
  /// shared by its registries, so that what it keeps is bounded by all their maps; null: the
  /// registry makes its own.
  std::shared_ptr<FreeMemoryReturner> free_memory;
  /// Memory set aside in the budget for each map being made or edited [bytes]: the limit of
  /// the process that makes it (map_worker.hpp).
  std::uint64_t assessment_memory_bytes = 0;
  /// Bytes of traversability graphs kept per map (PlanningMap's max_graph_bytes); 0: no bound.
  std::size_t max_graph_bytes = 0;
  /// With a store: versions kept per map, the current one included [-], >= 1.
  int versions_kept = 5;
  /// With a store: how a version's description is written beside it and read back (the
  /// server stores the API's Map message; proto_convert.hpp). Both must be set with a store.
  std::function<std::string(const MapSnapshot&)> encode_metadata;
  std::function<Result<MapSnapshot>(const std::string&)> decode_metadata;
};

/// Where one CREATING map is, for metrics.
struct CreationProgress {
  std::string id;
  std::string step;     ///< "queued", "loading", or the assessment's step (ground_filter ...).
  double progress = 0;  ///< MapSnapshot::progress().
};

/// Counts for metrics.
struct MapTotals {
  int creating = 0;
  int active = 0;
  int failed = 0;
  /// Sum over ACTIVE maps held in memory (with a store, the loaded ones) [bytes].
  std::size_t active_memory_bytes = 0;
  std::vector<CreationProgress> creating_progress;  ///< One per CREATING map (<= --max-maps).
};

/// One page of List.
struct MapPage {
  std::vector<MapSnapshot> maps;  ///< In id order.
  std::string last_id;            ///< Id of the last map when more follow; empty otherwise.
};

class MapRegistry {
 public:
  /// Called by a worker, outside the lock, when a map becomes ACTIVE or FAILED.
  using DoneListener = std::function<void(const MapSnapshot&)>;

  explicit MapRegistry(RegistryOptions options, DoneListener on_done = {});
  /// Stops the workers (Shutdown) and waits for any assessment in progress to stop.
  ~MapRegistry();
  MapRegistry(const MapRegistry&) = delete;
  MapRegistry& operator=(const MapRegistry&) = delete;

  /// Adds a CREATING map and queues its assessment; returns at once. An empty `id` gets a
  /// fresh "map-N". A FAILED map with the same id is replaced. Fails with kInvalidInput (bad
  /// id, blamed on "map_id"), kInvalidConfig (bad `config`), kMapAlreadyExists,
  /// kTooManyMaps, kShuttingDown. `config.num_threads` is replaced by the registry's.
  /// A file that is a saved model keeps the parameters it was assessed with: `config` is
  /// then ignored when `config_given` is false (the request set no terrain parameter), and
  /// must assess alike otherwise (kInvalidConfig naming the first field that differs).
  Result<MapSnapshot> Create(const std::string& id, MapSource source, AssessmentConfig config,
                             bool config_given = false);

  /// Makes the next version of ACTIVE map `request.id` (MapEditor::Update, which says how it
  /// fails); kMapNotActive while the map is being made here.
  Result<MapUpdate> Update(const MapEditRequest& request, const CallControl& call);
  /// Update calls on map `id` waiting for an edit being made (MapEditor::EditsWaiting).
  int EditsWaiting(const std::string& id) const { return editor_->EditsWaiting(id); }

  /// The map's state; kMapNotFound. With a store, an ACTIVE map is loaded if not held.
  Result<MapSnapshot> Get(const std::string& id) const;

  /// The planning map of an ACTIVE map, shared with the registry, at `version` (empty: the
  /// current one; with a store, loaded from it if not held); kMapNotFound, kMapVersionNotFound
  /// naming the versions kept, or kMapNotActive naming the state (and the failure of a FAILED
  /// map), or a store's failure to load it.
  Result<ActiveMap> GetActive(const std::string& id, const std::string& version = {}) const;
  /// After a plan on a map: lets go of maps no plan uses while those held pass the memory
  /// budget (MemoryBudget::FitMaps), since the graphs a plan builds or loads grow its map.
  void FitHeldMaps() const;

  /// Blocks until the map is ACTIVE or FAILED (returns it), `deadline` passes (returns it
  /// CREATING), or `should_stop` (polled every 50 ms; may be empty) returns true (returns
  /// it as it is). kMapNotFound, also when it is deleted while waiting.
  Result<MapSnapshot> WaitUntilDone(const std::string& id,
                                    std::chrono::steady_clock::time_point deadline,
                                    const std::function<bool()>& should_stop) const;

  /// Removes the map in any state (with a store, from the store: for every replica);
  /// kMapNotFound. A map being made stops at once (its worker process is killed; on this
  /// process's own thread, within one unit of work: a row of columns, a tile) and is
  /// discarded; plans holding the map finish normally.
  ServiceStatus Delete(const std::string& id);

  /// Up to `page_size` (>= 1) maps with ids greater than `after_id`, in id order.
  MapPage List(const std::string& after_id, int page_size) const;

  MapTotals Totals() const;

  /// Refuses new maps (kShuttingDown), fails queued maps and stops the ones being made (their
  /// maps fail with kShuttingDown: a worker process is killed at once; a build on this
  /// process's own thread that is still reading its file finishes the read first), then lets
  /// the threads exit. Idempotent.
  void Shutdown();

  /// After Shutdown: waits until no assessment is running or `deadline` passes; true when
  /// idle.
  bool WaitIdle(std::chrono::steady_clock::time_point deadline);

  const RegistryOptions& options() const { return options_; }

 private:
  struct Entry;

  // The job that makes `entry`'s map, on a queue thread.
  void Assess(const std::shared_ptr<Entry>& entry);
  // Ends `entry` FAILED with `failure`, or, with a map, publishes it and ends it ACTIVE.
  void Finish(const std::shared_ptr<Entry>& entry, Result<std::shared_ptr<const PlanningMap>> made,
              const PointCloud& cloud);
  // Builds the snapshot of `entry`; call with mutex_ held. Leaves memory_bytes to the caller
  // (it takes the planning map's own lock).
  MapSnapshot SnapshotLocked(const Entry& entry) const;
  // A planning map on `model` (terrain `terrain` of map `id`) with the registry's graph bound;
  // with a store, its graphs are kept there.
  std::shared_ptr<const PlanningMap> NewPlanningMap(std::shared_ptr<const TerrainModel> model,
                                                    std::vector<Prism> keep_out,
                                                    const std::string& id,
                                                    const std::string& terrain) const;
  // With a budget: `bytes` set aside for making map `id`; an empty reservation without one.
  Result<MemoryBudget::Reservation> ReserveForMaking(const std::string& id) const;
  // With a budget: whether map `id`'s new `map` may be held (see MemoryBudget::AdmitMap).
  ServiceStatus AdmitMade(const std::string& id, const PlanningMap& map) const;

  RegistryOptions options_;
  DoneListener on_done_;
  // Writes graphs to the store (with one); declared before what holds planning maps, so that it
  // is destroyed after them.
  std::shared_ptr<GraphWriter> graph_writer_;
  // Asked by the editor and the published maps when versions are let go (options_.free_memory
  // or the registry's own); declared before them, so that it outlives them.
  std::shared_ptr<FreeMemoryReturner> free_memory_;
  FreeMemoryReturner::Room free_memory_room_;
  std::unique_ptr<PublishedMaps> published_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // Any entry's state, or stopping_.
  std::map<std::string, std::shared_ptr<Entry>> making_;
  std::uint64_t next_generated_id_ = 1;
  bool stopping_ = false;

  std::unique_ptr<MapEditor> editor_;
  // Last, so that it is destroyed first: its threads end while everything they use lives.
  std::unique_ptr<AssessmentQueue> queue_;
};

}  // namespace strata::server
