#include "maps/map_registry.hpp"

#include <algorithm>
#include <atomic>
#include <new>
#include <utility>

#include <fmt/format.h>

#include "common/log.hpp"
#include "common/map_id.hpp"
#include "maps/memory_maps.hpp"
#include "maps/stored_maps.hpp"
#include "strata/io/saved_model.hpp"

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

// How often waiters re-check their caller's cancellation (it has no notification).
constexpr auto kCancellationPollPeriod = std::chrono::milliseconds(50);

const char* StateName(MapState state) {
  switch (state) {
    case MapState::kCreating: return "CREATING";
    case MapState::kActive: return "ACTIVE";
    case MapState::kFailed: return "FAILED";
  }
  return "UNKNOWN";
}

MapSourceInfo InfoOf(const MapSource& source) {
  if (const auto* file = std::get_if<FileMapSource>(&source)) {
    return FileSourceInfo{file->requested_path};
  }
  if (const auto* scene = std::get_if<SceneMapSource>(&source)) return *scene;
  return UploadSummary{std::get<UploadMapSource>(source).received_bytes};
}

}  // namespace

struct MapRegistry::Entry {
  std::string id;
  AssessmentConfig config;
  MapSource source;  // Moved out by the job that makes it.
  MapSourceInfo source_info;
  MapState state = MapState::kCreating;
  CreationStage stage = CreationStage::kQueued;
  std::optional<ServiceError> failure;
  std::size_t raw_point_count = 0;
  std::size_t dropped_nonfinite_point_count = 0;
  double load_s = 0;
  std::shared_ptr<const PlanningMap> planning;  // Set once ACTIVE; never changes after.
  int max_levels = 0;
  std::chrono::system_clock::time_point create_time;
  std::optional<std::chrono::system_clock::time_point> done_time;
  bool removed = false;  // Deleted or replaced: its job discards the result and stops.
  // While ASSESSING: the step under way and the fraction of it done.
  AssessmentStage step = AssessmentStage::kSorting;
  double step_fraction = 0;
  bool from_saved_model = false;  // A saved model's file: loaded, never assessed.
  std::string version;            // Known once made.
};

MapRegistry::MapRegistry(RegistryOptions options, DoneListener on_done)
    : options_(std::move(options)),
      on_done_(std::move(on_done)),
      free_memory_(options_.free_memory ? options_.free_memory
                                        : std::make_shared<FreeMemoryReturner>()),
      free_memory_room_(*free_memory_) {
  options_.max_concurrent_assessments = std::max(1, options_.max_concurrent_assessments);
  options_.max_maps = std::max(1, options_.max_maps);
  if (!options_.loader) options_.loader = LoadMapSource;
  if (!options_.build) {
    options_.build = [loader = options_.loader](MapBuildJob job,
                                                const BuildMonitor& monitor) -> Result<BuiltMap> {
      Expected<BuiltMap> built = BuildMapHere(std::move(job), monitor, loader);
      if (!built) return ServiceError::FromPlanner(built.error());
      return std::move(built).value();
    };
  }
  options_.versions_kept = std::max(1, options_.versions_kept);
  auto make_planning = [this](std::shared_ptr<const TerrainModel> model,
                              std::vector<Prism> keep_out, const std::string& id,
                              const std::string& terrain) {
    return NewPlanningMap(std::move(model), std::move(keep_out), id, terrain);
  };
  if (options_.store) {
    graph_writer_ = std::make_shared<GraphWriter>();
    StoredMapsOptions stored;
    stored.store = options_.store;
    stored.versions_kept = options_.versions_kept;
    stored.encode_metadata = options_.encode_metadata;
    stored.decode_metadata = options_.decode_metadata;
    stored.make_planning = make_planning;
    stored.free_memory = &free_memory_room_;
    if (options_.memory_budget) {
      stored.allowance = [budget = options_.memory_budget.get()] { return budget->MapAllowance(); };
    }
    published_ = std::make_unique<StoredMaps>(std::move(stored));
  } else {
    published_ = std::make_unique<MemoryMaps>();
  }
  if (options_.memory_budget) {
    options_.memory_budget->WatchMaps([this] { return published_->HeldBytes(); },
                                      [this](std::uint64_t target) { published_->TrimTo(target); });
  }
  queue_ = std::make_unique<AssessmentQueue>(options_.max_concurrent_assessments);
  MapEditorOptions editing;
  editing.published = published_.get();
  editing.queue = queue_.get();
  editing.build = options_.build;
  editing.make_planning = make_planning;
  editing.memory_budget = options_.memory_budget;
  editing.assessment_memory_bytes = options_.assessment_memory_bytes;
  editing.max_assessment_time_s = options_.max_assessment_time_s;
  editing.versions_kept = options_.versions_kept;
  editing.free_memory = &free_memory_room_;
  editing.stopping = [this] {
    std::lock_guard lock(mutex_);
    return stopping_;
  };
  editor_ = std::make_unique<MapEditor>(std::move(editing));
}

MapRegistry::~MapRegistry() {
  Shutdown();
  queue_.reset();  // Waits for the jobs still running: they use everything else.
  if (options_.memory_budget) options_.memory_budget->WatchMaps({}, {});
}

std::shared_ptr<const PlanningMap> MapRegistry::NewPlanningMap(
    std::shared_ptr<const TerrainModel> model, std::vector<Prism> keep_out, const std::string& id,
    const std::string& terrain) const {
  std::shared_ptr<const GraphArchive> archive;
  if (options_.store && !terrain.empty()) {
    archive = std::make_shared<StoredGraphs>(options_.store, graph_writer_, id, terrain);
  }
  return std::make_shared<PlanningMap>(std::move(model), std::move(keep_out),
                                       options_.max_graph_bytes, std::move(archive));
}

Result<MemoryBudget::Reservation> MapRegistry::ReserveForMaking(const std::string& id) const {
  if (!options_.memory_budget) return MemoryBudget::Reservation();
  return options_.memory_budget->Reserve(MemoryBudget::Use::kAssessments,
                                         options_.assessment_memory_bytes,
                                         "making map '" + id + "' (--max-assessment-memory)");
}

ServiceStatus MapRegistry::AdmitMade(const std::string& id, const PlanningMap& map) const {
  if (!options_.memory_budget) return OkStatus();
  return options_.memory_budget->AdmitMap(map.MemoryBytes(), "holding map '" + id + "'");
}

Result<MapSnapshot> MapRegistry::Create(const std::string& id, MapSource source,
                                        AssessmentConfig config, bool config_given) {
  if (!id.empty()) {
    if (ServiceStatus valid = ValidateMapId(id); !valid.ok()) return std::move(valid).error();
  }
  config.num_threads = options_.assessment_threads;
  if (Status valid = config.Validate(); !valid) {
    return ServiceError::FromPlanner(valid.error(), "terrain");
  }
  bool saved_model = false;
  if (const auto* file = std::get_if<FileMapSource>(&source);
      file != nullptr && IsSavedModelFile(file->file->ProcPath())) {
    // A saved model is assessed already: its parameters hold. Asking for others is an error
    // the client hears now, not after a queue.
    Expected<AssessmentConfig> saved = ReadSavedModelConfig(file->ToRead());
    if (!saved) return ServiceError::FromPlanner(saved.error(), "file.path");
    if (config_given) {
      if (Status same = CheckSavedModelParameters(config, *saved, "'" + file->requested_path + "'");
          !same) {
        return ServiceError::FromPlanner(same.error(), "terrain");
      }
    }
    config = *saved;
    config.num_threads = options_.assessment_threads;
    saved_model = true;
  }
  if (!id.empty()) {
    // An id published already is taken (creating the same map on two replicas at once is no
    // error: both make one version, PublishNew). Checked outside the lock: the store may be
    // a network file system.
    if (Result<std::vector<std::string>> kept = published_->Versions(id); kept.ok()) {
      return MakeError(ServiceErrorCode::kMapAlreadyExists,
                       "map '" + id + "' already exists (version " + kept.value().front() +
                           "): delete it first, choose another id" +
                           (published_->KeepsClouds() ? ", or UpdateMap it" : ""))
          .With("map_id", id);
    }
  }
  if (options_.memory_budget) {
    // Refused now if making it could not start: the client hears it at once, not after a
    // queue. Making it sets the memory aside for real (Assess).
    if (ServiceStatus room = options_.memory_budget->AdmitMap(
            options_.assessment_memory_bytes, "making map '" +
                                                  (id.empty() ? std::string("(new)") : id) +
                                                  "' (--max-assessment-memory)");
        !room.ok()) {
      return std::move(room).error();
    }
  }
  auto entry = std::make_shared<Entry>();
  entry->from_saved_model = saved_model;
  entry->config = config;
  entry->source_info = InfoOf(source);
  entry->source = std::move(source);
  entry->create_time = std::chrono::system_clock::now();

  std::unique_lock lock(mutex_);
  if (stopping_) {
    return MakeError(ServiceErrorCode::kShuttingDown,
                     "the server is shutting down and accepts no new maps; retry on another "
                     "replica");
  }
  std::string new_id = id;
  if (new_id.empty()) {
    do {
      new_id = "map-" + std::to_string(next_generated_id_++);
    } while (making_.count(new_id) != 0 || published_->Versions(new_id).ok());
  }
  if (const auto existing = making_.find(new_id); existing != making_.end()) {
    if (existing->second->state != MapState::kFailed) {
      return MakeError(ServiceErrorCode::kMapAlreadyExists,
                       "map '" + new_id + "' already exists (" +
                           StateName(existing->second->state) +
                           "): delete it first or choose another id")
          .With("map_id", new_id);
    }
    existing->second->removed = true;  // A FAILED map is replaced.
    making_.erase(existing);
  }
  // Maps held for good count against the limit: those being made or failed here, and the
  // published maps that cannot be let go (without a store).
  if (static_cast<int>(making_.size()) + published_->PinnedCount() >= options_.max_maps) {
    return MakeError(ServiceErrorCode::kTooManyMaps,
                     fmt::format("the server already holds its limit of {} maps (--max-maps): "
                                 "delete one first",
                                 options_.max_maps));
  }
  entry->id = new_id;
  making_.emplace(new_id, entry);
  MapSnapshot snapshot = SnapshotLocked(*entry);
  lock.unlock();
  AssessmentQueue::Job job;
  job.run = [this, entry] {
    Assess(entry);
    free_memory_room_.Request();  // Its scratch, gigabytes for a site.
  };
  job.drop = [this, entry] {
    Finish(entry,
           MakeError(ServiceErrorCode::kShuttingDown,
                     "the server shut down before assessing this map"),
           {});
  };
  if (!queue_->Post(std::move(job))) {
    Finish(entry,
           MakeError(ServiceErrorCode::kShuttingDown,
                     "the server shut down before assessing this map"),
           {});
  }
  changed_.notify_all();
  return snapshot;
}

Result<MapUpdate> MapRegistry::Update(const MapEditRequest& request, const CallControl& call) {
  {
    std::lock_guard lock(mutex_);
    if (const auto it = making_.find(request.id); it != making_.end()) {
      return MakeError(ServiceErrorCode::kMapNotActive,
                       "map '" + request.id + "' is " + StateName(it->second->state) +
                           " on this server: edit it once it is ACTIVE")
          .With("map_id", request.id);
    }
  }
  return editor_->Update(request, call);
}

Result<MapSnapshot> MapRegistry::Get(const std::string& id) const {
  std::unique_lock lock(mutex_);
  if (const auto it = making_.find(id); it != making_.end()) {
    MapSnapshot snapshot = SnapshotLocked(*it->second);
    const std::shared_ptr<const PlanningMap> planning = it->second->planning;
    lock.unlock();
    if (planning) snapshot.memory_bytes = planning->MemoryBytes();
    return snapshot;
  }
  lock.unlock();
  // The current version is loaded (if not held) so that the snapshot tells its memory.
  if (Result<ActiveMap> active = published_->Get(id, {}); !active.ok()) {
    return std::move(active).error();
  }
  return published_->Describe(id);
}

void MapRegistry::FitHeldMaps() const {
  if (options_.memory_budget) options_.memory_budget->FitMaps();
}

Result<ActiveMap> MapRegistry::GetActive(const std::string& id, const std::string& version) const {
  std::unique_lock lock(mutex_);
  const auto it = making_.find(id);
  if (it == making_.end()) {
    lock.unlock();
    return published_->Get(id, version);
  }
  const Entry& entry = *it->second;
  std::string message = "map '" + id + "' is " + StateName(entry.state);
  if (entry.state == MapState::kCreating) {
    message +=
        ": its terrain assessment has not finished; wait for ACTIVE (GetMap, or "
        "CreateMap with wait) and retry";
  } else if (entry.failure.has_value()) {
    message += " (" + entry.failure->message + "): create it again";
  }
  return MakeError(ServiceErrorCode::kMapNotActive, std::move(message))
      .With("map_id", id)
      .With("state", StateName(entry.state));
}

Result<MapSnapshot> MapRegistry::WaitUntilDone(const std::string& id,
                                               SteadyClock::time_point deadline,
                                               const std::function<bool()>& should_stop) const {
  std::unique_lock lock(mutex_);
  const auto it = making_.find(id);
  if (it == making_.end()) {
    lock.unlock();
    return Get(id);  // Published already (or no such map).
  }
  const std::shared_ptr<Entry> entry = it->second;
  while (true) {
    if (entry->removed) {
      return MakeError(ServiceErrorCode::kMapNotFound,
                       "map '" + id + "' was deleted while being created")
          .With("map_id", id);
    }
    if (entry->state != MapState::kCreating || SteadyClock::now() >= deadline ||
        (should_stop && should_stop())) {
      break;
    }
    changed_.wait_until(lock, std::min(deadline, SteadyClock::now() + kCancellationPollPeriod));
  }
  MapSnapshot snapshot = SnapshotLocked(*entry);
  const std::shared_ptr<const PlanningMap> planning = entry->planning;
  lock.unlock();
  if (planning) snapshot.memory_bytes = planning->MemoryBytes();
  return snapshot;
}

ServiceStatus MapRegistry::Delete(const std::string& id) {
  std::unique_lock lock(mutex_);
  std::shared_ptr<Entry> entry;
  if (const auto it = making_.find(id); it != making_.end()) {
    entry = it->second;
    entry->removed = true;  // Its job, queued or running, stops and discards what it made.
    making_.erase(it);
  }
  lock.unlock();
  changed_.notify_all();
  ServiceStatus deleted = published_->Delete(id);
  if (!deleted.ok() && entry == nullptr) return deleted;
  return OkStatus();
}

MapPage MapRegistry::List(const std::string& after_id, int page_size) const {
  page_size = std::max(1, page_size);
  MapPage page;
  std::map<std::string, MapSnapshot> found;
  std::vector<std::shared_ptr<const PlanningMap>> planning;
  {
    std::lock_guard lock(mutex_);
    for (auto it = making_.upper_bound(after_id);
         it != making_.end() && static_cast<int>(found.size()) <= page_size; ++it) {
      found.emplace(it->first, SnapshotLocked(*it->second));
    }
  }
  // One more than a page from each side tells whether more follow. A map being made here
  // again after it failed shadows nothing: only FAILED maps can be replaced, never published.
  for (MapSnapshot& map : published_->List(after_id, page_size + 1)) {
    const std::string id = map.id;
    found.emplace(id, std::move(map));
  }
  for (auto& [id, map] : found) {
    if (static_cast<int>(page.maps.size()) == page_size) {
      page.last_id = page.maps.back().id;
      break;
    }
    page.maps.push_back(std::move(map));
  }
  return page;
}

MapTotals MapRegistry::Totals() const {
  MapTotals totals;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, entry] : making_) {
      switch (entry->state) {
        case MapState::kCreating: {
          ++totals.creating;
          const MapSnapshot snapshot = SnapshotLocked(*entry);
          totals.creating_progress.push_back(
              {id,
               snapshot.stage == CreationStage::kAssessing
                   ? AssessmentStageName(snapshot.assessment_step)
                   : (snapshot.stage == CreationStage::kLoading ? "loading" : "queued"),
               snapshot.progress()});
          break;
        }
        case MapState::kActive: break;  // Published: counted below.
        case MapState::kFailed: ++totals.failed; break;
      }
    }
  }
  totals.active = published_->HeldCount();
  totals.active_memory_bytes = published_->HeldBytes();
  return totals;
}

void MapRegistry::Shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
  }
  changed_.notify_all();
  queue_->Shutdown();  // Maps still queued fail with kShuttingDown; running jobs stop.
}

bool MapRegistry::WaitIdle(SteadyClock::time_point deadline) { return queue_->WaitIdle(deadline); }

void MapRegistry::Assess(const std::shared_ptr<Entry>& entry) {
  MapBuildJob job;
  {
    std::lock_guard lock(mutex_);
    if (entry->removed) return;
    job.source = std::visit(
        [](auto&& source) -> BuildSource { return std::forward<decltype(source)>(source); },
        std::move(entry->source));
    entry->source = SceneMapSource{};  // Frees uploaded points (and closes a file) once read.
    entry->stage = CreationStage::kLoading;
    job.config = entry->config;
    job.saved_model = entry->from_saved_model;
  }
  changed_.notify_all();
  job.limits = options_.load_limits;
  job.keep_cloud = published_->KeepsClouds() && !job.saved_model;  // Edits start from it.

  // The build reports its figures and its step to the map (Map.progress), and stops when the
  // map is deleted, the server shuts down, or its time is up.
  const auto deadline =
      options_.max_assessment_time_s > 0
          ? SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                     std::chrono::duration<double>(options_.max_assessment_time_s))
          : SteadyClock::time_point::max();
  std::atomic<bool> timed_out{false};
  BuildMonitor monitor;
  monitor.on_loaded = [this, &entry](std::size_t raw, std::size_t dropped, double load_s) {
    {
      std::lock_guard lock(mutex_);
      entry->raw_point_count = raw;
      entry->dropped_nonfinite_point_count = dropped;
      entry->load_s = load_s;
      if (!entry->from_saved_model) entry->stage = CreationStage::kAssessing;
    }
    changed_.notify_all();
  };
  monitor.on_progress = [this, &entry](AssessmentStage step, double fraction) {
    std::lock_guard lock(mutex_);
    entry->step = step;
    entry->step_fraction = fraction;
  };
  monitor.should_stop = [this, &entry, deadline, &timed_out] {
    if (SteadyClock::now() >= deadline) timed_out = true;
    std::lock_guard lock(mutex_);
    return timed_out || entry->removed || stopping_;
  };

  // Nothing below may throw past this function: a job that died would leave maps CREATING
  // for ever.
  try {
    Result<MemoryBudget::Reservation> making = ReserveForMaking(entry->id);
    if (!making.ok()) {
      Finish(entry, std::move(making).error(), {});
      return;
    }
    // The worker's memory is set aside until the map it made is loaded here (no larger).
    Result<BuiltMap> built = options_.build(std::move(job), monitor);
    {
      std::lock_guard lock(mutex_);
      if (entry->removed) return;  // Cancelled: nobody wants the result.
    }
    if (!built.ok()) {
      const ServiceError& error = built.error();
      const auto* code = std::get_if<ErrorCode>(&error.code);
      if (code != nullptr && *code == ErrorCode::kCancelled && timed_out) {
        Finish(entry,
               MakeError(ErrorCode::kDeadlineExceeded,
                         fmt::format("making this map took longer than the server allows "
                                     "(--max-assessment-time-s {} s): use a coarser "
                                     "terrain.resolution_m or a smaller cloud",
                                     options_.max_assessment_time_s)),
               {});
      } else if (code != nullptr && *code == ErrorCode::kCancelled) {
        Finish(entry,
               MakeError(ServiceErrorCode::kShuttingDown,
                         "the server shut down while assessing this map: create it again on a "
                         "running replica"),
               {});
      } else {
        Finish(entry, error, {});
      }
      return;
    }
    BuiltMap& map = built.value();
    const std::shared_ptr<const PlanningMap> planning =
        NewPlanningMap(std::move(map.model), {}, entry->id, map.version);
    making.value().Release();
    if (ServiceStatus admitted = AdmitMade(entry->id, *planning); !admitted.ok()) {
      Finish(entry, std::move(admitted).error(), {});
      return;
    }
    const int max_levels = planning->model().surfaces().max_valid_levels();
    {
      std::lock_guard lock(mutex_);
      entry->max_levels = max_levels;
      entry->version = map.version;
    }
    Finish(entry, planning, map.cloud);
  } catch (const std::bad_alloc&) {
    Finish(entry,
           MakeError(ErrorCode::kResourceExhausted,
                     "the server ran out of memory assessing this map: use a coarser "
                     "terrain.resolution_m or a smaller cloud"),
           {});
  } catch (const std::exception& e) {
    Finish(entry,
           MakeError(ServiceErrorCode::kInternal,
                     std::string("assessment failed unexpectedly: ") + e.what()),
           {});
  }
}

void MapRegistry::Finish(const std::shared_ptr<Entry>& entry,
                         Result<std::shared_ptr<const PlanningMap>> made, const PointCloud& cloud) {
  if (made.ok()) {
    // Published as it will be once ACTIVE, for every replica that loads it from the store.
    MapSnapshot described;
    {
      std::lock_guard lock(mutex_);
      if (entry->removed) return;
      described = SnapshotLocked(*entry);
    }
    const TerrainModel& model = made.value()->model();
    described.state = MapState::kActive;
    described.stage = CreationStage::kDone;
    described.done_time = std::chrono::system_clock::now();
    described.version = entry->version;
    described.versions = {entry->version};
    described.summary = model.summary();
    described.grid = model.grid();
    if (ServiceStatus published = published_->PublishNew(described, made.value(), cloud);
        !published.ok()) {
      made = std::move(published).error();
    } else {
      std::lock_guard lock(mutex_);
      // Deleted while it was being published: what was published goes too.
      if (entry->removed) {
        (void)published_->Delete(entry->id);
        return;
      }
    }
  }
  MapSnapshot snapshot;
  std::shared_ptr<const PlanningMap> planning;
  {
    std::lock_guard lock(mutex_);
    if (entry->removed) return;
    entry->stage = CreationStage::kDone;
    entry->done_time = std::chrono::system_clock::now();
    if (made.ok()) {
      entry->state = MapState::kActive;
      entry->planning = std::move(made).value();
      // Published: the entry lives on only for those waiting on it.
      if (const auto it = making_.find(entry->id); it != making_.end() && it->second == entry) {
        making_.erase(it);
      }
    } else {
      entry->state = MapState::kFailed;
      entry->failure = std::move(made).error();
      entry->failure->field_violations.clear();  // Fields of the planner, not of a request.
      entry->failure->metadata["map_id"] = entry->id;
    }
    snapshot = SnapshotLocked(*entry);
    planning = entry->planning;
  }
  if (planning) snapshot.memory_bytes = planning->MemoryBytes();
  // The listener runs before waiters are woken, outside the lock (it may call back).
  if (on_done_) on_done_(snapshot);
  changed_.notify_all();
}

MapSnapshot MapRegistry::SnapshotLocked(const Entry& entry) const {
  MapSnapshot s;
  s.id = entry.id;
  s.state = entry.state;
  s.stage = entry.stage;
  s.failure = entry.failure;
  s.source = entry.source_info;
  s.config = entry.config;
  s.raw_point_count = entry.raw_point_count;
  s.dropped_nonfinite_point_count = entry.dropped_nonfinite_point_count;
  s.load_s = entry.load_s;
  s.max_levels = entry.max_levels;
  s.assessment_step = entry.step;
  s.assessment_step_fraction = entry.step_fraction;
  s.from_saved_model = entry.from_saved_model;
  s.create_time = entry.create_time;
  s.done_time = entry.done_time;
  if (entry.state == MapState::kActive) {
    s.version = entry.version;
    s.versions = {entry.version};
  }
  if (entry.planning) {
    s.summary = entry.planning->model().summary();
    s.grid = entry.planning->model().grid();
  }
  return s;
}

}  // namespace strata::server
