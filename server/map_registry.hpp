#pragma once
/// The maps a server hosts: an id → map store and the small pool of threads that make new
/// maps off the RPC threads (each in a worker process of its own in the server:
/// RegistryOptions::build, map_worker.hpp). No gRPC here, so it is tested on its own (and can run
/// under ThreadSanitizer, which Debian's gRPC cannot: scripts/test.sh runs that build in CI).
///
/// Concurrency: one mutex guards the id → entry table and every entry's mutable fields; it
/// is held only for bookkeeping, never while loading, assessing or planning. A plan copies
/// the map's shared_ptr<const PlanningMap> (GetActive) and releases the lock, so creating or
/// deleting maps never blocks planning on others, and a deleted map lives on until the last
/// plan running on it lets go. An ACTIVE map's version never changes; UpdateMap makes another.
///
/// With a map store (RegistryOptions::store), the store is what holds ACTIVE maps: a map
/// assessed here is written there and becomes visible to every replica, the registry keeps only
/// the maps being created (or failed) here, and ACTIVE maps are loaded on demand into a
/// MapCache within the server's memory budget (--max-memory). Every request looks the map up in the
/// store, so a map deleted or updated on another replica is refused or planned on its new version
/// at once.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "map_build.hpp"
#include "map_cache.hpp"
#include "map_store.hpp"
#include "memory_budget.hpp"
#include "service_error.hpp"
#include "strata/cloud_io.hpp"
#include "strata/map_edit.hpp"
#include "strata/planner.hpp"
#include "strata/point_cloud.hpp"
#include "strata/prism.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/terrain_config.hpp"
#include "strata/terrain_model.hpp"

namespace strata::server {

enum class MapState { kCreating, kActive, kFailed };

/// Where a CREATING map is.
enum class CreationStage { kQueued, kLoading, kAssessing, kDone };

/// What remains known of a source once its points are consumed.
struct UploadSummary {
  std::uint64_t received_bytes = 0;
};
using MapSourceInfo = std::variant<FileMapSource, SceneMapSource, UploadSummary>;

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
  /// The file is a saved model (strata/saved_model.hpp): loaded, not assessed.
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
  /// How a map is made: in a worker process (map_worker.hpp; what the server does). Empty:
  /// on the registry's own thread with `loader` (BuildMapHere).
  MapBuilder build;
  /// How sources are read when `build` is empty (tests substitute one that waits on a latch).
  CloudLoader loader = LoadMapSource;
  /// Longest the making of one map may take once started, reading its source included [s],
  /// >= 0; past it the map fails with kDeadlineExceeded (a worker process is killed at once,
  /// an assessment here stops within a unit of work). 0: no limit.
  double max_assessment_time_s = 0;
  /// The map store shared with other replicas; null keeps maps in this registry only.
  std::shared_ptr<MapStore> store;
  /// The server's memory budget (memory_budget.hpp); null: none. The registry counts its maps
  /// there, lets a store's maps go when room is needed, sets assessment_memory_bytes aside
  /// for each map being made or edited, and admits a map made only when it fits.
  std::shared_ptr<MemoryBudget> memory_budget;
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

/// A new version made by MapRegistry::Update, and what it cost.
struct MapUpdate {
  MapSnapshot map;
  double apply_s = 0;                   ///< Editing the cloud [s].
  double reassess_s = 0;                ///< Reassessing the touched terrain [s].
  double write_s = 0;                   ///< Writing and publishing the version [s].
  double total_s = 0;                   ///< All of it, with loading the base when not held [s].
  bool full_reassessment = false;       ///< The edits changed what the whole map depends on.
  std::string full_reason;              ///< Why, when full_reassessment.
  std::int64_t reassessed_columns = 0;  ///< Grid columns assessed again.
};

/// A planning map and the version it is.
struct ActiveMap {
  std::shared_ptr<const PlanningMap> map;
  std::string version;
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

  /// Checks that `id` is 1–64 characters from [A-Za-z0-9._-]; kInvalidInput otherwise.
  static ServiceStatus ValidateId(const std::string& id);

  /// Adds a CREATING map and queues its assessment; returns at once. An empty `id` gets a
  /// fresh "map-N". A FAILED map with the same id is replaced. Fails with kInvalidInput (bad
  /// id, blamed on "map_id"), kInvalidConfig (bad `config`), kMapAlreadyExists,
  /// kTooManyMaps, kShuttingDown. `config.num_threads` is replaced by the registry's.
  /// A file that is a saved model keeps the parameters it was assessed with: `config` is
  /// then ignored when `config_given` is false (the request set no terrain parameter), and
  /// must assess alike otherwise (kInvalidConfig naming the first field that differs).
  Result<MapSnapshot> Create(const std::string& id, MapSource source, AssessmentConfig config,
                             bool config_given = false);

  /// Makes a new version of ACTIVE map `id` from `edits` of version `base_version` (empty:
  /// the current one): the cloud edited, the touched terrain reassessed (ReassessRegion), the
  /// keep-out zones cleared first when `clear_keep_out`, then `add_keep_out` added; written to
  /// the store and published if the map is still at the base. Without a base version, an
  /// edit that another one overtook is redone on the new current version (a few times at
  /// most, then kMapChanged). Needs a store
  /// (kMapStoreRequired). Fails with kMapNotFound, kMapNotActive (CREATING here), kMapChanged,
  /// kEditNeedsCloud (a map made from a saved model), kInvalidInput naming the edit field, or
  /// as the store does.
  Result<MapUpdate> Update(const std::string& id, const std::string& base_version,
                           const std::vector<MapEdit>& edits,
                           const std::vector<Prism>& add_keep_out, bool clear_keep_out);

  /// The map's state; kMapNotFound. With a store, an ACTIVE map is loaded if not held.
  Result<MapSnapshot> Get(const std::string& id) const;

  /// The planning map of an ACTIVE map, shared with the registry, at `version` (empty: the
  /// current one; with a store, loaded from it if not held); kMapNotFound, kMapVersionNotFound
  /// naming the versions kept, or kMapNotActive naming the state (and the failure of a FAILED
  /// map), or a store's failure to load it.
  Result<ActiveMap> GetActive(const std::string& id, const std::string& version = {}) const;

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

  // One attempt of Update: kMapChanged when another edit published first.
  Result<MapUpdate> UpdateOnce(const std::string& id, const std::string& base_version,
                               const std::vector<MapEdit>& edits,
                               const std::vector<Prism>& add_keep_out, bool clear_keep_out);
  void WorkerLoop();
  void Assess(const std::shared_ptr<Entry>& entry);
  // Builds the snapshot of `entry`; call with mutex_ held. Leaves memory_bytes to the caller
  // (see FillMemory) because it takes the planning map's own lock.
  MapSnapshot SnapshotLocked(const Entry& entry) const;
  static void FillMemory(const std::shared_ptr<const PlanningMap>& map, MapSnapshot* snapshot);
  // Bytes of the maps held, in the table and in the cache (the budget's count).
  std::uint64_t HeldMapBytes() const;
  // A planning map on `model` with the registry's graph bound.
  std::shared_ptr<const PlanningMap> NewPlanningMap(std::shared_ptr<const TerrainModel> model,
                                                    std::vector<Prism> keep_out = {}) const;
  // With a budget: `bytes` set aside for making or editing map `id`; an empty reservation
  // without one.
  Result<MemoryBudget::Reservation> ReserveForMaking(const std::string& id) const;
  // With a budget: whether map `id`'s new `map` may be held (see MemoryBudget::AdmitMap).
  ServiceStatus AdmitMade(const std::string& id, const PlanningMap& map) const;
  void Finish(const std::shared_ptr<Entry>& entry,
              Result<std::shared_ptr<const PlanningMap>> outcome);

  // With a store: writes the version assessed (or loaded) for `entry` and makes it the map's
  // first version; kMapAlreadyExists when another replica made the id another map meanwhile.
  ServiceStatus PublishCreated(const std::shared_ptr<Entry>& entry, const PointCloud& cloud,
                               const TerrainModel& model);
  // With a store: the versions of `id` kept (newest first), or kMapNotFound.
  Result<std::vector<std::string>> StoredVersions(const std::string& id) const;
  // With a store: `version` of `id`, from the cache or loaded into it.
  Result<ActiveMap> LoadStored(const std::string& id, const std::string& version) const;
  // With a store: the snapshot of a stored version from its metadata.
  Result<MapSnapshot> StoredSnapshot(const std::string& id,
                                     const std::vector<std::string>& versions) const;

  RegistryOptions options_;
  DoneListener on_done_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // Any entry's state, the queue, or stopping_.
  std::map<std::string, std::shared_ptr<Entry>> maps_;
  std::deque<std::shared_ptr<Entry>> queue_;
  std::uint64_t next_generated_id_ = 1;
  int running_assessments_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
  // With a store: the versions loaded here (mutable: loading on demand is not a change).
  std::unique_ptr<MapCache> cache_;
};

}  // namespace strata::server
