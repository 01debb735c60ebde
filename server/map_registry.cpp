#include "map_registry.hpp"

#include "log.hpp"

#include "strata/saved_model.hpp"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <new>
#include <utility>

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

constexpr std::size_t kMaxIdLength = 64;
// How often waiters re-check their caller's cancellation (it has no notification).
constexpr auto kCancellationPollPeriod = std::chrono::milliseconds(50);

double SecondsSince(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

// "600 s", "0.5 s".
std::string SecondsText(double seconds) {
  char digits[32];
  const auto [end, ec] = std::to_chars(digits, digits + sizeof digits, seconds);
  return std::string(digits, ec == std::errc() ? end : digits) + " s";
}

bool IsIdCharacter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

const char* StateName(MapState state) {
  switch (state) {
    case MapState::kCreating: return "CREATING";
    case MapState::kActive: return "ACTIVE";
    case MapState::kFailed: return "FAILED";
  }
  return "UNKNOWN";
}

MapSourceInfo InfoOf(const MapSource& source) {
  if (const auto* file = std::get_if<FileMapSource>(&source)) return *file;
  if (const auto* scene = std::get_if<SceneMapSource>(&source)) return *scene;
  return UploadSummary{std::get<UploadMapSource>(source).received_bytes};
}

}  // namespace

namespace {

// Most valid surfaces stacked in one column of the model.
int MaxLevels(const TerrainModel& model) {
  const SurfaceMap& surfaces = model.surfaces();
  const Eigen::Vector3i size = model.grid().size;
  int most = 0;
  for (int iy = 0; iy < size.y(); ++iy) {
    for (int ix = 0; ix < size.x(); ++ix) {
      const auto column = surfaces.Column(ix, iy);
      const auto valid = std::count_if(column.begin(), column.end(),
                                       [](const ColumnSurface& s) { return s.valid; });
      most = std::max(most, static_cast<int>(valid));
    }
  }
  return most;
}

}  // namespace

struct MapRegistry::Entry {
  std::string id;
  AssessmentConfig config;
  MapSource source;  // Moved out by the worker that assesses it.
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
  bool removed = false;  // Deleted or replaced: its worker discards the result and stops.
  // While ASSESSING: the step under way and the fraction of it done.
  AssessmentStage step = AssessmentStage::kSorting;
  double step_fraction = 0;
  bool from_saved_model = false;  // A saved model's file: loaded, never assessed.
  std::string version;            // Known once loaded.
  std::vector<Prism> keep_out;
};

double MapSnapshot::progress() const {
  // Loading takes the first tenth; the assessment's steps the rest, in the rough shares of
  // their time on large maps.
  constexpr double kStepShare[] = {0.05, 0.3, 0.2, 0.35};  // sorting ... fields.
  switch (stage) {
    case CreationStage::kQueued: return 0.0;
    case CreationStage::kLoading: return 0.05;
    case CreationStage::kAssessing: {
      // Summed the same way at the end of a step and at the start of the next, so the
      // progress never steps back by a rounding error.
      const auto step = static_cast<std::size_t>(assessment_step);
      double progress = 0.1;
      for (std::size_t i = 0; i < step; ++i) progress += kStepShare[i];
      return progress + kStepShare[step] * assessment_step_fraction;
    }
    case CreationStage::kDone: return 1.0;
  }
  return 0.0;
}

MapRegistry::MapRegistry(RegistryOptions options, DoneListener on_done)
    : options_(std::move(options)), on_done_(std::move(on_done)) {
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
  if (options_.store) {
    MapCache::Allowance allowance;
    if (options_.memory_budget) {
      allowance = [budget = options_.memory_budget.get()] { return budget->MapAllowance(); };
    }
    cache_ = std::make_unique<MapCache>(std::move(allowance));
  }
  if (options_.memory_budget) {
    options_.memory_budget->WatchMaps([this] { return HeldMapBytes(); },
                                      [this](std::uint64_t target) {
                                        if (cache_) cache_->TrimTo(target);
                                      });
  }
  workers_.reserve(static_cast<std::size_t>(options_.max_concurrent_assessments));
  for (int i = 0; i < options_.max_concurrent_assessments; ++i) {
    workers_.emplace_back([this] { WorkerLoop(); });
  }
}

MapRegistry::~MapRegistry() {
  Shutdown();
  for (std::thread& worker : workers_) worker.join();
  if (options_.memory_budget) options_.memory_budget->WatchMaps({}, {});
}

std::uint64_t MapRegistry::HeldMapBytes() const {
  std::vector<std::shared_ptr<const PlanningMap>> held;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, entry] : maps_) {
      if (entry->planning) held.push_back(entry->planning);
    }
  }
  std::uint64_t bytes = cache_ ? cache_->ResidentBytes() : 0;
  for (const auto& map : held) bytes += map->MemoryBytes();
  return bytes;
}

std::shared_ptr<const PlanningMap> MapRegistry::NewPlanningMap(
    std::shared_ptr<const TerrainModel> model, std::vector<Prism> keep_out) const {
  return std::make_shared<PlanningMap>(std::move(model), std::move(keep_out),
                                       options_.max_graph_bytes);
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

ServiceStatus MapRegistry::ValidateId(const std::string& id) {
  const bool well_formed =
      !id.empty() && id.size() <= kMaxIdLength && std::all_of(id.begin(), id.end(), IsIdCharacter);
  if (well_formed) return OkStatus();
  std::string shown = id.substr(0, kMaxIdLength);
  std::replace_if(
      shown.begin(), shown.end(), [](char c) { return !IsIdCharacter(c); }, '?');
  return MakeError(ErrorCode::kInvalidInput,
                   "map id '" + shown + (id.size() > kMaxIdLength ? "...'" : "'") +
                       " is not valid: use 1 to 64 characters from A-Z a-z 0-9 . _ -")
      .Blame("map_id");
}

Result<MapSnapshot> MapRegistry::Create(const std::string& id, MapSource source,
                                        AssessmentConfig config, bool config_given) {
  if (!id.empty()) {
    if (ServiceStatus valid = ValidateId(id); !valid.ok()) return std::move(valid).error();
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
      if (const std::optional<std::string> field = FirstDifference(config, *saved)) {
        return MakeError(ErrorCode::kInvalidConfig,
                         "'" + file->requested_path + "' is a saved model, assessed with other " +
                             "terrain parameters (its " + *field +
                             " differs): leave terrain unset, or create the map from the " +
                             "point cloud")
            .Blame("terrain");
      }
    }
    config = *saved;
    config.num_threads = options_.assessment_threads;
    saved_model = true;
  }
  if (options_.store && !id.empty()) {
    // Creating the same map on two replicas at once is not an error (both produce one
    // version; PublishCreated), but an id the store already holds is. Checked outside the
    // lock: the store may be a network file system.
    if (Result<std::string> current = options_.store->Current(id); current.ok()) {
      return MakeError(ServiceErrorCode::kMapAlreadyExists,
                       "map '" + id + "' already exists in the map store (version " +
                           current.value() + "): delete it first, choose another id, or " +
                           "UpdateMap it")
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
    } while (maps_.count(new_id) != 0 || (options_.store && options_.store->Current(new_id).ok()));
  }

  auto existing = maps_.find(new_id);
  if (existing != maps_.end()) {
    if (existing->second->state != MapState::kFailed) {
      return MakeError(ServiceErrorCode::kMapAlreadyExists,
                       "map '" + new_id + "' already exists (" +
                           StateName(existing->second->state) +
                           "): delete it first or choose another id")
          .With("map_id", new_id);
    }
    existing->second->removed = true;  // A FAILED map is replaced.
    maps_.erase(existing);
  }
  if (static_cast<int>(maps_.size()) >= options_.max_maps) {
    return MakeError(ServiceErrorCode::kTooManyMaps, "the server already holds its limit of " +
                                                         std::to_string(options_.max_maps) +
                                                         " maps (--max-maps): delete one first");
  }
  entry->id = new_id;
  maps_.emplace(new_id, entry);
  queue_.push_back(entry);
  MapSnapshot snapshot = SnapshotLocked(*entry);
  lock.unlock();
  changed_.notify_all();
  return snapshot;
}

namespace {

ServiceError NotFound(const std::string& id) {
  return MakeError(ServiceErrorCode::kMapNotFound,
                   "no map '" + id + "' on this server: ListMaps shows the maps it holds")
      .With("map_id", id);
}

ServiceError VersionNotFound(const std::string& id, const std::string& version,
                             const std::vector<std::string>& kept) {
  std::string listed;
  for (const std::string& v : kept) listed += (listed.empty() ? "" : ", ") + v;
  return MakeError(ServiceErrorCode::kMapVersionNotFound,
                   "map '" + id + "' has no version '" + version + "' (kept: " + listed +
                       "): plan on one of those, or leave map_version empty for the current")
      .With("map_id", id)
      .With("map_version", version)
      .Blame("map_version");
}

}  // namespace

Result<MapSnapshot> MapRegistry::Get(const std::string& id) const {
  std::unique_lock lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
    lock.unlock();
    if (!options_.store) return NotFound(id);
    Result<std::vector<std::string>> versions = StoredVersions(id);
    if (!versions.ok()) return std::move(versions).error();
    Result<ActiveMap> active = LoadStored(id, versions.value().front());
    if (!active.ok()) return std::move(active).error();
    Result<MapSnapshot> snapshot = StoredSnapshot(id, versions.value());
    if (snapshot.ok()) FillMemory(active.value().map, &snapshot.value());
    return snapshot;
  }
  MapSnapshot snapshot = SnapshotLocked(*it->second);
  const std::shared_ptr<const PlanningMap> planning = it->second->planning;
  lock.unlock();
  FillMemory(planning, &snapshot);
  return snapshot;
}

Result<ActiveMap> MapRegistry::GetActive(const std::string& id, const std::string& version) const {
  std::unique_lock lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
    lock.unlock();
    if (!options_.store) return NotFound(id).Blame("map_id");
    Result<std::vector<std::string>> versions = StoredVersions(id);
    if (!versions.ok()) return std::move(versions).error();
    const std::vector<std::string>& kept = versions.value();
    if (!version.empty() && std::find(kept.begin(), kept.end(), version) == kept.end()) {
      return VersionNotFound(id, version, kept);
    }
    return LoadStored(id, version.empty() ? kept.front() : version);
  }
  const Entry& entry = *it->second;
  if (entry.state == MapState::kActive) {
    if (!version.empty() && version != entry.version) {
      return VersionNotFound(id, version, {entry.version});
    }
    return ActiveMap{entry.planning, entry.version};
  }
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

Result<std::vector<std::string>> MapRegistry::StoredVersions(const std::string& id) const {
  Result<std::vector<std::string>> versions = options_.store->Versions(id);
  if (!versions.ok() || versions.value().empty()) {
    cache_->Drop(id);  // Deleted, perhaps by another replica: free it here too.
    return NotFound(id).Blame("map_id");
  }
  return versions;
}

Result<ActiveMap> MapRegistry::LoadStored(const std::string& id, const std::string& version) const {
  Result<std::shared_ptr<const PlanningMap>> map =
      cache_->Get(id, version, [&]() -> Result<std::shared_ptr<const PlanningMap>> {
        Result<std::string> metadata = options_.store->LoadMetadata(id, version);
        if (!metadata.ok()) return std::move(metadata).error();
        Result<MapSnapshot> described = options_.decode_metadata(metadata.value());
        if (!described.ok()) return std::move(described).error();
        Result<std::shared_ptr<const TerrainModel>> model = options_.store->LoadModel(id, version);
        if (!model.ok()) return std::move(model).error();
        return NewPlanningMap(std::move(model).value(), described.value().keep_out);
      });
  if (!map.ok()) return std::move(map).error();
  return ActiveMap{std::move(map).value(), version};
}

Result<MapSnapshot> MapRegistry::StoredSnapshot(const std::string& id,
                                                const std::vector<std::string>& versions) const {
  Result<std::string> metadata = options_.store->LoadMetadata(id, versions.front());
  if (!metadata.ok()) return std::move(metadata).error();
  Result<MapSnapshot> snapshot = options_.decode_metadata(metadata.value());
  if (!snapshot.ok()) return snapshot;
  snapshot.value().id = id;
  snapshot.value().version = versions.front();
  snapshot.value().versions = versions;
  return snapshot;
}

Result<MapSnapshot> MapRegistry::WaitUntilDone(const std::string& id,
                                               SteadyClock::time_point deadline,
                                               const std::function<bool()>& should_stop) const {
  std::unique_lock lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
    lock.unlock();
    // With a store, a map created here leaves the table once ACTIVE: it is in the store.
    if (options_.store) return Get(id);
    return MakeError(ServiceErrorCode::kMapNotFound, "no map '" + id + "' on this server")
        .With("map_id", id);
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
  FillMemory(planning, &snapshot);
  return snapshot;
}

ServiceStatus MapRegistry::Delete(const std::string& id) {
  std::unique_lock lock(mutex_);
  const auto it = maps_.find(id);
  std::shared_ptr<Entry> entry;
  if (it != maps_.end()) {
    entry = it->second;
    entry->removed = true;
    maps_.erase(it);
    // A queued assessment is dropped now rather than run for nothing.
    queue_.erase(std::remove(queue_.begin(), queue_.end(), entry), queue_.end());
  }
  lock.unlock();
  changed_.notify_all();
  if (options_.store) {
    cache_->Drop(id);
    ServiceStatus deleted = options_.store->Delete(id);
    if (!deleted.ok() && entry == nullptr) return NotFound(id);
    return OkStatus();
  }
  if (entry == nullptr) return NotFound(id);
  return OkStatus();  // `entry` (and its planning map, if no plan holds it) is freed here.
}

Result<MapUpdate> MapRegistry::Update(const std::string& id, const std::string& base_version,
                                      const std::vector<MapEdit>& edits,
                                      const std::vector<Prism>& add_keep_out, bool clear_keep_out) {
  // Without a base version the edits apply to whatever version is current when they are
  // published: a compare-and-swap lost to another edit is redone on the new current one.
  constexpr int kMaxAttempts = 8;
  for (int attempt = 1;; ++attempt) {
    Result<MapUpdate> update = UpdateOnce(id, base_version, edits, add_keep_out, clear_keep_out);
    const auto* code = update.ok() ? nullptr : std::get_if<ServiceErrorCode>(&update.error().code);
    const bool lost_race = code != nullptr && (*code == ServiceErrorCode::kMapChanged ||
                                               *code == ServiceErrorCode::kMapVersionNotFound);
    if (!lost_race || !base_version.empty() || attempt == kMaxAttempts) return update;
    LogInfo("map_update_retry").Add("map", id).Add("attempt", attempt);
  }
}

Result<MapUpdate> MapRegistry::UpdateOnce(const std::string& id, const std::string& base_version,
                                          const std::vector<MapEdit>& edits,
                                          const std::vector<Prism>& add_keep_out,
                                          bool clear_keep_out) {
  const auto start = SteadyClock::now();
  if (!options_.store) {
    return MakeError(ServiceErrorCode::kMapStoreRequired,
                     "UpdateMap makes a new version in the map store, and this server has none: "
                     "start it with --map-store DIR")
        .With("map_id", id);
  }
  {
    std::lock_guard lock(mutex_);
    if (const auto it = maps_.find(id); it != maps_.end()) {
      return MakeError(ServiceErrorCode::kMapNotActive,
                       "map '" + id + "' is " + StateName(it->second->state) +
                           " on this server: edit it once it is ACTIVE")
          .With("map_id", id);
    }
  }
  Result<std::vector<std::string>> versions = StoredVersions(id);
  if (!versions.ok()) return std::move(versions).error();
  const std::string current = versions.value().front();
  if (!base_version.empty() && base_version != current) {
    return MakeError(ServiceErrorCode::kMapChanged,
                     "map '" + id + "' is at version " + current + ", not " + base_version +
                         ": read it again (GetMap) and redo the edits on it")
        .With("map_id", id)
        .With("current_version", current)
        .Blame("base_version");
  }
  Result<ActiveMap> base = LoadStored(id, current);
  if (!base.ok()) return std::move(base).error();
  Result<MapSnapshot> described = StoredSnapshot(id, versions.value());
  if (!described.ok()) return std::move(described).error();
  MapSnapshot snapshot = std::move(described).value();
  const TerrainModel& base_model = base.value().map->model();

  MapUpdate update;
  std::shared_ptr<const TerrainModel> model = base.value().map->model_ptr();
  PointCloud cloud;
  const bool edits_cloud = !edits.empty();
  if (snapshot.from_saved_model) {
    return MakeError(ServiceErrorCode::kEditNeedsCloud,
                     "map '" + id + "' was made from a saved model, which keeps no point cloud " +
                         "to edit: create the map from its point cloud to edit it")
        .With("map_id", id);
  }
  // The base cloud, its edited copy and the new model are made here: memory is set aside
  // for them as for making a map.
  Result<MemoryBudget::Reservation> making = ReserveForMaking(id);
  if (!making.ok()) return std::move(making).error();
  Result<PointCloud> stored_cloud = options_.store->LoadCloud(id, current);
  if (!stored_cloud.ok()) return std::move(stored_cloud).error();
  cloud = std::move(stored_cloud).value();
  if (edits_cloud) {
    const auto apply_start = SteadyClock::now();
    Expected<PointCloud> edited = ApplyEdits(cloud, edits, base_model);
    if (!edited) return ServiceError::FromPlanner(edited.error(), edited.error().field);
    update.apply_s = SecondsSince(apply_start);
    const auto reassess_start = SteadyClock::now();
    Expected<Reassessment> reassessed =
        ReassessRegion(base_model, cloud, edited.value(), EditBounds(edits));
    if (!reassessed) return ServiceError::FromPlanner(reassessed.error());
    model = reassessed->model;
    update.full_reassessment = reassessed->path == ReassessmentPath::kFull;
    update.full_reason = reassessed->full_reason;
    update.reassessed_columns = reassessed->reassessed_columns;
    update.reassess_s = SecondsSince(reassess_start);
    cloud = std::move(edited).value();
  }
  std::vector<Prism> keep_out = clear_keep_out ? std::vector<Prism>{} : snapshot.keep_out;
  keep_out.insert(keep_out.end(), add_keep_out.begin(), add_keep_out.end());
  const std::string version = MapStore::VersionOf(cloud, model->config(), keep_out);

  snapshot.summary = model->summary();
  // The version's source is the edited cloud: raw = dropped + input holds for every version.
  snapshot.raw_point_count = cloud.size() + snapshot.dropped_nonfinite_point_count;
  snapshot.grid = model->grid();
  snapshot.max_levels = MaxLevels(*model);
  snapshot.keep_out = keep_out;
  snapshot.done_time = std::chrono::system_clock::now();
  snapshot.version = version;
  snapshot.versions = {version};
  for (const std::string& kept : versions.value()) {
    if (static_cast<int>(snapshot.versions.size()) == options_.versions_kept) break;
    if (kept != version) snapshot.versions.push_back(kept);
  }
  const auto write_start = SteadyClock::now();
  if (ServiceStatus put = options_.store->PutVersion(id, version, cloud, *model,
                                                     options_.encode_metadata(snapshot));
      !put.ok()) {
    return std::move(put).error();
  }
  if (ServiceStatus published =
          options_.store->PublishUpdate(id, current, version, options_.versions_kept);
      !published.ok()) {
    return std::move(published).error();
  }
  update.write_s = SecondsSince(write_start);
  auto planning = NewPlanningMap(model, keep_out);
  cloud = PointCloud();
  making.value().Release();
  if (ServiceStatus admitted = AdmitMade(id, *planning); !admitted.ok()) {
    return std::move(admitted).error();  // Written and published: it loads when there is room.
  }
  FillMemory(planning, &snapshot);
  cache_->Insert(id, version, std::move(planning));
  update.map = std::move(snapshot);
  update.total_s = SecondsSince(start);
  return update;
}

MapPage MapRegistry::List(const std::string& after_id, int page_size) const {
  page_size = std::max(1, page_size);
  MapPage page;
  std::vector<std::shared_ptr<const PlanningMap>> planning;
  std::map<std::string, MapSnapshot> local;  // With a store, merged with the store's ids.
  {
    std::lock_guard lock(mutex_);
    auto it = after_id.empty() ? maps_.begin() : maps_.upper_bound(after_id);
    for (; it != maps_.end() && static_cast<int>(local.size()) <= page_size; ++it) {
      local.emplace(it->first, SnapshotLocked(*it->second));
      planning.push_back(it->second->planning);
    }
  }
  {
    std::size_t i = 0;  // `local` is in the order the entries were visited.
    for (auto& [id, snapshot] : local) FillMemory(planning[i++], &snapshot);
  }
  if (options_.store) {
    // One more than a page from each side tells whether more follow.
    Result<std::vector<std::string>> ids = options_.store->ListIds(after_id, page_size + 1);
    for (const std::string& id : ids.ok() ? ids.value() : std::vector<std::string>{}) {
      if (local.count(id) != 0) continue;  // Being created here again after a failure.
      Result<std::vector<std::string>> versions = options_.store->Versions(id);
      if (!versions.ok() || versions.value().empty()) continue;  // Deleted meanwhile.
      Result<MapSnapshot> snapshot = StoredSnapshot(id, versions.value());
      if (!snapshot.ok()) continue;
      const std::shared_ptr<const PlanningMap> held = cache_->Peek(id, versions.value().front());
      FillMemory(held, &snapshot.value());
      local.emplace(id, std::move(snapshot).value());
    }
  }
  for (auto& [id, snapshot] : local) {
    if (static_cast<int>(page.maps.size()) == page_size) {
      page.last_id = page.maps.back().id;
      break;
    }
    page.maps.push_back(std::move(snapshot));
  }
  return page;
}

MapTotals MapRegistry::Totals() const {
  MapTotals totals;
  std::vector<std::shared_ptr<const PlanningMap>> active;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, entry] : maps_) {
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
        case MapState::kActive:
          ++totals.active;
          active.push_back(entry->planning);
          break;
        case MapState::kFailed: ++totals.failed; break;
      }
    }
  }
  for (const auto& map : active) totals.active_memory_bytes += map->MemoryBytes();
  if (cache_) {
    totals.active += cache_->Count();
    totals.active_memory_bytes += cache_->ResidentBytes();
  }
  return totals;
}

void MapRegistry::Shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    for (const std::shared_ptr<Entry>& entry : queue_) {
      entry->state = MapState::kFailed;
      entry->stage = CreationStage::kDone;
      entry->failure = MakeError(ServiceErrorCode::kShuttingDown,
                                 "the server shut down before assessing this map");
    }
    queue_.clear();
  }
  changed_.notify_all();
}

bool MapRegistry::WaitIdle(SteadyClock::time_point deadline) {
  std::unique_lock lock(mutex_);
  return changed_.wait_until(lock, deadline, [this] { return running_assessments_ == 0; });
}

void MapRegistry::WorkerLoop() {
  while (true) {
    std::shared_ptr<Entry> entry;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      entry = queue_.front();
      queue_.pop_front();
      ++running_assessments_;
    }
    Assess(entry);
    {
      std::lock_guard lock(mutex_);
      --running_assessments_;
    }
    changed_.notify_all();
  }
}

void MapRegistry::Assess(const std::shared_ptr<Entry>& entry) {
  MapBuildJob job;
  {
    std::lock_guard lock(mutex_);
    if (entry->removed) return;
    job.source = std::move(entry->source);
    entry->source = SceneMapSource{};  // Frees uploaded points once assessed.
    entry->stage = CreationStage::kLoading;
    job.config = entry->config;
    job.saved_model = entry->from_saved_model;
  }
  changed_.notify_all();
  job.limits = options_.load_limits;
  job.keep_cloud = options_.store != nullptr && !job.saved_model;  // The store keeps it.

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

  // Nothing below may throw past this function: a worker that died would leave maps
  // CREATING for ever.
  try {
    Result<MemoryBudget::Reservation> making = ReserveForMaking(entry->id);
    if (!making.ok()) {
      Finish(entry, std::move(making).error());
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
        Finish(entry, MakeError(ErrorCode::kDeadlineExceeded,
                                "making this map took longer than the server allows "
                                "(--max-assessment-time-s " +
                                    SecondsText(options_.max_assessment_time_s) +
                                    "): use a coarser terrain.resolution_m or a smaller cloud"));
      } else if (code != nullptr && *code == ErrorCode::kCancelled) {
        Finish(entry, MakeError(ServiceErrorCode::kShuttingDown,
                                "the server shut down while assessing this map: create it again "
                                "on a running replica"));
      } else {
        Finish(entry, error);
      }
      return;
    }
    BuiltMap& map = built.value();
    PointCloud cloud = std::move(map.cloud);
    const std::shared_ptr<const PlanningMap> planning = NewPlanningMap(std::move(map.model));
    making.value().Release();
    if (ServiceStatus admitted = AdmitMade(entry->id, *planning); !admitted.ok()) {
      Finish(entry, std::move(admitted).error());
      return;
    }
    const int max_levels = MaxLevels(planning->model());
    {
      std::lock_guard lock(mutex_);
      entry->max_levels = max_levels;
      entry->version = map.version;
    }
    if (options_.store) {
      ServiceStatus published = PublishCreated(entry, cloud, planning->model());
      if (!published.ok()) {
        Finish(entry, std::move(published).error());
        return;
      }
    }
    Finish(entry, planning);
  } catch (const std::bad_alloc&) {
    Finish(entry, MakeError(ErrorCode::kResourceExhausted,
                            "the server ran out of memory assessing this map: use a coarser "
                            "terrain.resolution_m or a smaller cloud"));
  } catch (const std::exception& e) {
    Finish(entry, MakeError(ServiceErrorCode::kInternal,
                            std::string("assessment failed unexpectedly: ") + e.what()));
  }
}

void MapRegistry::Finish(const std::shared_ptr<Entry>& entry,
                         Result<std::shared_ptr<const PlanningMap>> outcome) {
  MapSnapshot snapshot;
  std::shared_ptr<const PlanningMap> planning;
  {
    std::lock_guard lock(mutex_);
    if (entry->removed) return;
    entry->stage = CreationStage::kDone;
    entry->done_time = std::chrono::system_clock::now();
    if (outcome.ok()) {
      entry->state = MapState::kActive;
      entry->planning = std::move(outcome).value();
      if (options_.store) {
        // The store holds it now: this server keeps it in the cache like any stored map,
        // and the entry lives on only for those waiting on it.
        cache_->Insert(entry->id, entry->version, entry->planning);
        if (const auto it = maps_.find(entry->id); it != maps_.end() && it->second == entry) {
          maps_.erase(it);
        }
      }
    } else {
      entry->state = MapState::kFailed;
      entry->failure = std::move(outcome).error();
      entry->failure->field_violations.clear();  // Fields of the planner, not of a request.
      entry->failure->metadata["map_id"] = entry->id;
    }
    snapshot = SnapshotLocked(*entry);
    planning = entry->planning;
  }
  FillMemory(planning, &snapshot);
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
  s.keep_out = entry.keep_out;
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

ServiceStatus MapRegistry::PublishCreated(const std::shared_ptr<Entry>& entry,
                                          const PointCloud& cloud, const TerrainModel& model) {
  MapSnapshot described;
  {
    std::lock_guard lock(mutex_);
    described = SnapshotLocked(*entry);
  }
  // As it will be once ACTIVE, for replicas that load it from the store.
  described.state = MapState::kActive;
  described.stage = CreationStage::kDone;
  described.done_time = std::chrono::system_clock::now();
  described.version = entry->version;
  described.versions = {entry->version};
  described.summary = model.summary();
  described.grid = model.grid();
  const std::string& id = entry->id;
  LogInfo("map_version_writing").Add("map", id).Add("version", entry->version);
  if (ServiceStatus put = options_.store->PutVersion(id, entry->version, cloud, model,
                                                     options_.encode_metadata(described));
      !put.ok()) {
    return put;
  }
  return options_.store->PublishNew(id, entry->version);
}

void MapRegistry::FillMemory(const std::shared_ptr<const PlanningMap>& map, MapSnapshot* snapshot) {
  if (map) snapshot->memory_bytes = map->MemoryBytes();
}

}  // namespace strata::server
