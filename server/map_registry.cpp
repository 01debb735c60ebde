#include "map_registry.hpp"

#include "strata/saved_model.hpp"

#include <algorithm>
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

Expected<LoadedCloud> LoadMapSource(MapSource source, const CloudLoadLimits& limits) {
  if (auto* file = std::get_if<FileMapSource>(&source)) {
    return ::strata::LoadMapSource(FileSource{file->resolved_path.string()}, limits);
  }
  if (auto* scene = std::get_if<SceneMapSource>(&source)) {
    return ::strata::LoadMapSource(*scene, limits);
  }
  return SanitizeCloud(std::move(std::get<UploadMapSource>(source).points), limits);
}

namespace {

void ReplaceAll(std::string* text, const std::string& from, const std::string& to) {
  if (from.empty()) return;
  for (std::size_t at = text->find(from); at != std::string::npos;
       at = text->find(from, at + to.size())) {
    text->replace(at, from.size(), to);
  }
}

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
  workers_.reserve(static_cast<std::size_t>(options_.max_concurrent_assessments));
  for (int i = 0; i < options_.max_concurrent_assessments; ++i) {
    workers_.emplace_back([this] { WorkerLoop(); });
  }
}

MapRegistry::~MapRegistry() {
  Shutdown();
  for (std::thread& worker : workers_) worker.join();
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
      file != nullptr && IsSavedModelFile(file->resolved_path.string())) {
    // A saved model is assessed already: its parameters hold. Asking for others is an error
    // the client hears now, not after a queue.
    Expected<AssessmentConfig> saved = ReadSavedModelConfig(file->resolved_path.string());
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
    } while (maps_.count(new_id) != 0);
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

Result<MapSnapshot> MapRegistry::Get(const std::string& id) const {
  std::unique_lock lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
    return MakeError(ServiceErrorCode::kMapNotFound,
                     "no map '" + id + "' on this server: ListMaps shows the maps it holds")
        .With("map_id", id);
  }
  MapSnapshot snapshot = SnapshotLocked(*it->second);
  const std::shared_ptr<const PlanningMap> planning = it->second->planning;
  lock.unlock();
  FillMemory(planning, &snapshot);
  return snapshot;
}

Result<std::shared_ptr<const PlanningMap>> MapRegistry::GetActive(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
    return MakeError(ServiceErrorCode::kMapNotFound,
                     "no map '" + id + "' on this server: ListMaps shows the maps it holds")
        .With("map_id", id)
        .Blame("map_id");
  }
  const Entry& entry = *it->second;
  if (entry.state == MapState::kActive) return entry.planning;
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
  const auto it = maps_.find(id);
  if (it == maps_.end()) {
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
  if (it == maps_.end()) {
    return MakeError(ServiceErrorCode::kMapNotFound, "no map '" + id + "' on this server")
        .With("map_id", id);
  }
  const std::shared_ptr<Entry> entry = it->second;
  entry->removed = true;
  maps_.erase(it);
  // A queued assessment is dropped now rather than run for nothing.
  queue_.erase(std::remove(queue_.begin(), queue_.end(), entry), queue_.end());
  lock.unlock();
  changed_.notify_all();
  return OkStatus();  // `entry` (and its planning map, if no plan holds it) is freed here.
}

MapPage MapRegistry::List(const std::string& after_id, int page_size) const {
  page_size = std::max(1, page_size);
  MapPage page;
  std::vector<std::shared_ptr<const PlanningMap>> planning;
  {
    std::lock_guard lock(mutex_);
    auto it = after_id.empty() ? maps_.begin() : maps_.upper_bound(after_id);
    for (; it != maps_.end() && static_cast<int>(page.maps.size()) < page_size; ++it) {
      page.maps.push_back(SnapshotLocked(*it->second));
      planning.push_back(it->second->planning);
    }
    if (it != maps_.end() && !page.maps.empty()) page.last_id = page.maps.back().id;
  }
  for (std::size_t i = 0; i < page.maps.size(); ++i) FillMemory(planning[i], &page.maps[i]);
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
  MapSource source;
  AssessmentConfig config;
  {
    std::lock_guard lock(mutex_);
    if (entry->removed) return;
    source = std::move(entry->source);
    entry->source = SceneMapSource{};  // Frees uploaded points once assessed.
    entry->stage = CreationStage::kLoading;
    config = entry->config;
  }
  changed_.notify_all();

  // Nothing below may throw past this function: a worker that died would leave maps
  // CREATING for ever.
  try {
    std::optional<Expected<std::shared_ptr<const TerrainModel>>> model;
    if (entry->from_saved_model) {
      const auto load_start = SteadyClock::now();
      model.emplace(LoadModel(std::get<FileMapSource>(source).resolved_path.string()));
      std::lock_guard lock(mutex_);
      if (entry->removed) return;
      entry->load_s = SecondsSince(load_start);
      if (*model) entry->raw_point_count = (**model)->summary().input_points;
    } else {
      const auto load_start = SteadyClock::now();
      Expected<LoadedCloud> loaded = options_.loader(std::move(source), options_.load_limits);
      const double load_s = SecondsSince(load_start);
      if (!loaded) {
        Finish(entry, ServiceError::FromPlanner(loaded.error()));
        return;
      }
      {
        std::lock_guard lock(mutex_);
        if (entry->removed) return;
        entry->raw_point_count = loaded->raw_point_count;
        entry->dropped_nonfinite_point_count = loaded->dropped_nonfinite;
        entry->load_s = load_s;
        entry->stage = CreationStage::kAssessing;
      }
      changed_.notify_all();
      // The assessment reports its step to the map (Map.progress) and stops when the map is
      // deleted or the server shuts down.
      AssessmentControl control;
      control.on_progress = [this, &entry](AssessmentStage step, double fraction) {
        std::lock_guard lock(mutex_);
        entry->step = step;
        entry->step_fraction = fraction;
      };
      control.should_stop = [this, &entry] {
        std::lock_guard lock(mutex_);
        return entry->removed || stopping_;
      };
      model.emplace(TerrainModel::Assess(loaded->points, config, control));
    }  // The cloud is freed here; the model keeps what planning needs.
    {
      std::lock_guard lock(mutex_);
      if (entry->removed) return;  // Cancelled: nobody wants the result.
    }
    if (!*model && model->error().code == ErrorCode::kCancelled) {
      Finish(entry, MakeError(ServiceErrorCode::kShuttingDown,
                              "the server shut down while assessing this map: create it again "
                              "on a running replica"));
      return;
    }
    if (!*model) {
      Finish(entry, ServiceError::FromPlanner(model->error()));
      return;
    }
    const int max_levels = MaxLevels(*model->value());
    {
      std::lock_guard lock(mutex_);
      entry->max_levels = max_levels;
    }
    Finish(entry, std::shared_ptr<const PlanningMap>(
                      std::make_shared<PlanningMap>(std::move(*model).value())));
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
    } else {
      entry->state = MapState::kFailed;
      entry->failure = std::move(outcome).error();
      entry->failure->field_violations.clear();  // Fields of the planner, not of a request.
      entry->failure->metadata["map_id"] = entry->id;
      // Messages name the file as the client gave it, not where it lives on the server.
      if (const auto* file = std::get_if<FileMapSource>(&entry->source_info)) {
        ReplaceAll(&entry->failure->message, file->resolved_path.string(), file->requested_path);
      }
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
  if (entry.planning) {
    s.summary = entry.planning->model().summary();
    s.grid = entry.planning->model().grid();
  }
  return s;
}

void MapRegistry::FillMemory(const std::shared_ptr<const PlanningMap>& map, MapSnapshot* snapshot) {
  if (map) snapshot->memory_bytes = map->MemoryBytes();
}

}  // namespace strata::server
