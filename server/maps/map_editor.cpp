#include "maps/map_editor.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <future>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "common/log.hpp"
#include "maps/map_store.hpp"
#include "strata/common/seconds_since.hpp"

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;
using common::SecondsSince;

// How often a caller waiting for its edit looks at its cancellation (it has no notification).
constexpr auto kCancellationPollPeriod = std::chrono::milliseconds(50);

// Most Update calls one batch makes into a version: their answers wait for all of it.
constexpr std::size_t kMaxBatchUpdates = 64;

// Times an edit is published again on versions of keep-out zones alone that won the race.
constexpr int kMaxRepublishes = 4;

bool Has(const ServiceError& error, ServiceErrorCode code) {
  return error.code == ServiceError::Code(code);
}

// The call's end, when it came before the version was ready: nothing is published. `current`
// is the version the map stays at; empty when the edit ended while waiting for its batch.
std::optional<ServiceError> CallEnded(const CallControl& call, const std::string& id,
                                      const std::string& current) {
  const std::string stays =
      current.empty() ? "its edits were not made" : "the map stays at version " + current;
  if (call.cancelled && call.cancelled()) {
    return MakeError(ErrorCode::kCancelled,
                     "the call was cancelled before the new version of "
                     "map '" +
                         id + "' was made: " + stays)
        .With("map_id", id);
  }
  if (WorkSecondsLeft(call.LeftSeconds()) <= 0) {
    return MakeError(ErrorCode::kDeadlineExceeded,
                     "the call's deadline passed before the new version of map '" + id +
                         "' was made: " + stays +
                         "; allow more time (the stats of an UpdateMap that succeeds say how "
                         "long an edit takes)")
        .With("map_id", id);
  }
  return std::nullopt;
}

// Whether CallEnded would fail the call, without making its message (for polls).
bool Ended(const CallControl& call) {
  return (call.cancelled && call.cancelled()) || WorkSecondsLeft(call.LeftSeconds()) <= 0;
}

// Points the scans of `request` bring (an obstacle's are known only once it is applied).
std::size_t ScanPoints(const MapEditRequest& request) {
  std::size_t points = 0;
  for (const MapEdit& edit : request.edits) points += edit.points ? edit.points->size() : 0;
  return points;
}

ServiceError ShuttingDown() {
  return MakeError(ServiceErrorCode::kShuttingDown,
                   "the server is shutting down and makes no new versions; retry on another "
                   "replica");
}

// An edit job between the caller and the queue's thread.
struct EditRun {
  enum class State { kQueued, kRunning, kDone };
  std::mutex mutex;
  std::condition_variable changed;
  State state = State::kQueued;
  bool abandoned = false;  // The caller stopped waiting: a running job stops.
  std::optional<Result<BuiltMap>> result;

  void Finish(Result<BuiltMap> outcome) {
    {
      std::lock_guard lock(mutex);
      result = std::move(outcome);
      state = State::kDone;
    }
    changed.notify_all();
  }
};

}  // namespace

struct MapEditor::Waiting {
  const MapEditRequest* request;
  const CallControl* call;
  SteadyClock::time_point start;
  bool taken = false;  // In a batch being made.
  std::optional<Result<MapUpdate>> result;
};

Result<MapUpdate> MapEditor::Update(const MapEditRequest& request, const CallControl& call) {
  // Keep-out zones alone take no slot and are made at once: they wait for no batch. With a
  // base version an edit is a compare-and-swap on that version: made alone.
  if (request.edits.empty()) return UpdateRetrying(request, call);
  Result<MapUpdate> update =
      request.base_version.empty() ? UpdateInBatch(request, call) : UpdateRetrying(request, call);
  // An edit of the cloud let go of its scratch, and of what its version does not share with
  // the base's model and graphs once the plans on the base end. Room for the next version's
  // new arrays, the size of this one's, stays free for them; the rest goes back
  // (free_memory.hpp).
  if (options_.free_memory != nullptr) {
    options_.free_memory->Request(update.ok() ? update.value().new_bytes : 0);
  }
  return update;
}

int MapEditor::EditsWaiting(const std::string& id) const {
  std::lock_guard lock(batches_mutex_);
  const auto it = batches_.find(id);
  return it == batches_.end() ? 0 : static_cast<int>(it->second.waiting.size());
}

Result<MapUpdate> MapEditor::UpdateInBatch(const MapEditRequest& request, const CallControl& call) {
  Waiting me{&request, &call, SteadyClock::now(), false, std::nullopt};
  std::unique_lock lock(batches_mutex_);
  batches_[request.id].waiting.push_back(&me);
  for (;;) {
    if (me.result) return std::move(*me.result);
    // The map's entry stays while this call waits in it or is in its batch being made.
    Batches& batches = batches_.at(request.id);
    if (!me.taken) {
      if (std::optional<ServiceError> ended = CallEnded(call, request.id, "")) {
        std::erase(batches.waiting, &me);
        if (batches.waiting.empty() && !batches.making) batches_.erase(request.id);
        return *ended;
      }
      if (!batches.making) {
        // Make the next batch: the edits that waited, in their order, this one among them
        // unless the bounds leave it for the batch after.
        std::vector<Waiting*> batch;
        std::size_t points = 0;
        while (!batches.waiting.empty() && batch.size() < kMaxBatchUpdates) {
          Waiting* next = batches.waiting.front();
          const std::size_t more = ScanPoints(*next->request);
          if (!batch.empty() && points + more > kMaxEditPoints) break;
          points += more;
          next->taken = true;
          batch.push_back(next);
          batches.waiting.pop_front();
        }
        batches.making = true;
        lock.unlock();
        MakeBatch(batch);
        lock.lock();
        Batches& after = batches_.at(request.id);
        after.making = false;
        if (after.waiting.empty()) batches_.erase(request.id);
        batches_changed_.notify_all();
        continue;
      }
    }
    // No notification for a cancelled call: look at it now and then.
    batches_changed_.wait_for(lock, kCancellationPollPeriod);
  }
}

void MapEditor::MakeBatch(const std::vector<Waiting*>& batch) {
  const auto give = [this](Waiting* waiting, Result<MapUpdate> result) {
    if (result.ok()) result.value().total_s = SecondsSince(waiting->start);
    std::lock_guard lock(batches_mutex_);
    waiting->result.emplace(std::move(result));
  };
  if (batch.size() == 1) {
    give(batch.front(), UpdateRetrying(*batch.front()->request, *batch.front()->call));
    return;
  }
  // One request: the edits in order; the zones as applying the requests in turn leaves them.
  MapEditRequest combined;
  combined.id = batch.front()->request->id;
  CallControl any;  // Ends once every call of the batch has ended.
  any.deadline = SteadyClock::time_point::min();
  for (const Waiting* waiting : batch) {
    const MapEditRequest& request = *waiting->request;
    combined.edits.insert(combined.edits.end(), request.edits.begin(), request.edits.end());
    if (request.clear_keep_out) {
      combined.clear_keep_out = true;
      combined.add_keep_out.clear();
    }
    combined.add_keep_out.insert(combined.add_keep_out.end(), request.add_keep_out.begin(),
                                 request.add_keep_out.end());
    any.deadline = std::max(any.deadline, waiting->call->deadline);
  }
  any.cancelled = [&batch] {
    return std::all_of(batch.begin(), batch.end(),
                       [](const Waiting* waiting) { return Ended(*waiting->call); });
  };
  Result<MapUpdate> made = UpdateRetrying(combined, any);
  if (!made.ok() && (made.error().code == ServiceError::Code(ErrorCode::kInvalidInput) ||
                     made.error().code == ServiceError::Code(ErrorCode::kResourceExhausted))) {
    // An edit of the batch (or all of them together) is refused: each alone, so that only the
    // one at fault fails, with its own edit's index.
    for (Waiting* waiting : batch) give(waiting, UpdateRetrying(*waiting->request, *waiting->call));
    return;
  }
  if (made.ok()) made.value().merged_updates = static_cast<int>(batch.size());
  for (Waiting* waiting : batch) {
    // A batch that every call left is not published: each call hears of its own end.
    std::optional<ServiceError> ended;
    if (!made.ok() && Ended(any)) ended = CallEnded(*waiting->call, combined.id, "");
    give(waiting, ended ? Result<MapUpdate>(*ended) : made);
  }
}

Result<MapUpdate> MapEditor::UpdateRetrying(const MapEditRequest& request,
                                            const CallControl& call) {
  // Without a base version the edits apply to whatever version is current when they are
  // published: a compare-and-swap lost to another edit is redone on the new current one.
  constexpr int kMaxAttempts = 8;
  for (int attempt = 1;; ++attempt) {
    Result<MapUpdate> update = UpdateOnce(request, call);
    const bool lost_race =
        !update.ok() && (Has(update.error(), ServiceErrorCode::kMapChanged) ||
                         Has(update.error(), ServiceErrorCode::kMapVersionNotFound));
    if (!lost_race || !request.base_version.empty() || attempt == kMaxAttempts) return update;
    LogInfo("map_update_retry").Add("map", request.id).Add("attempt", attempt);
  }
}

Result<MapUpdate> MapEditor::UpdateOnce(const MapEditRequest& request, const CallControl& call) {
  const auto start = SteadyClock::now();
  const std::string& id = request.id;
  PublishedMaps& published = *options_.published;
  if (!published.KeepsClouds()) return MapStoreRequired(id);
  Result<std::vector<std::string>> versions = published.Versions(id);
  if (!versions.ok()) return std::move(versions).error();
  std::string current = versions.value().front();  // The base; moves only with a republish.
  if (!request.base_version.empty() && request.base_version != current) {
    return MakeError(ServiceErrorCode::kMapChanged,
                     "map '" + id + "' is at version " + current + ", not " + request.base_version +
                         ": read it again (GetMap) and redo the edits on it")
        .With("map_id", id)
        .With("current_version", current)
        .Blame("base_version");
  }
  Result<MapSnapshot> described = published.Describe(id);
  if (!described.ok()) return std::move(described).error();
  MapSnapshot map = std::move(described).value();
  if (map.from_saved_model) {
    return MakeError(ServiceErrorCode::kEditNeedsCloud,
                     "map '" + id + "' was made from a saved model, which keeps no point cloud " +
                         "to edit: create the map from its point cloud to edit it")
        .With("map_id", id);
  }
  // A cloud read or edited and a new model are held while the version is made: memory is set
  // aside for them as for making a map (keep-out zones alone hold nothing new, and setting it
  // aside would make room by letting go of the maps held).
  MemoryBudget::Reservation making;
  const auto set_aside = [&]() -> ServiceStatus {
    if (!options_.memory_budget) return OkStatus();
    Result<MemoryBudget::Reservation> reserved = options_.memory_budget->Reserve(
        MemoryBudget::Use::kAssessments, options_.assessment_memory_bytes,
        "editing map '" + id + "' (--max-assessment-memory)");
    if (!reserved.ok()) return std::move(reserved).error();
    making = std::move(reserved).value();
    return OkStatus();
  };
  BuiltMap built;
  std::string terrain;                               // What the new version is made of.
  std::shared_ptr<const PlanningMap> base_planning;  // For keep-out zones alone.
  if (!request.edits.empty()) {
    if (ServiceStatus reserved = set_aside(); !reserved.ok()) return std::move(reserved).error();
    Result<BuiltMap> edited = RunEditJob(request, current, call);
    if (!edited.ok()) return std::move(edited).error();
    built = std::move(edited).value();
    terrain = built.version;  // Named without zones (MapStore::VersionOf).
  } else {
    // Keep-out zones alone: the base's terrain (cloud and model) under a new version, and its
    // graphs, which zones are not part of.
    Result<ActiveMap> base = published.Get(id, current);
    if (!base.ok()) return std::move(base).error();
    base_planning = base.value().map;
    built.model = base_planning->model_ptr();
    Result<std::string> known = published.TerrainOf(id, current);
    if (!known.ok()) return std::move(known).error();
    terrain = std::move(known).value();
    if (terrain.empty()) {  // A version of layout 1: its cloud goes to a terrain of its own.
      if (ServiceStatus reserved = set_aside(); !reserved.ok()) return std::move(reserved).error();
      Result<PointCloud> cloud = published.LoadCloud(id, current);
      if (!cloud.ok()) return std::move(cloud).error();
      built.cloud = std::move(cloud).value();
      terrain = MapStore::TerrainOf(built.cloud, built.model->config());
    }
  }
  if (std::optional<ServiceError> ended = CallEnded(call, id, current)) return *ended;

  // The version's zones: the request's on top of (or instead of) the current version's, and
  // its name and kept list; again when the edit is published on another current version.
  const auto name_version = [&](const std::vector<Prism>& current_zones,
                                const std::vector<std::string>& kept_versions) {
    std::vector<Prism> zones = request.clear_keep_out ? std::vector<Prism>{} : current_zones;
    zones.insert(zones.end(), request.add_keep_out.begin(), request.add_keep_out.end());
    map.version = MapStore::VersionOf(terrain, zones);
    map.versions = {map.version};
    for (const std::string& kept : kept_versions) {
      if (static_cast<int>(map.versions.size()) == options_.versions_kept) break;
      if (kept != map.version) map.versions.push_back(kept);
    }
    map.keep_out = zones;
    return zones;
  };
  std::vector<Prism> keep_out = name_version(map.keep_out, versions.value());
  const TerrainModel& model = *built.model;
  map.summary = model.summary();
  if (built.edit) {
    // The version's source is the edited cloud: raw = dropped + input holds for every version.
    map.raw_point_count = built.edit->cloud_points + map.dropped_nonfinite_point_count;
  }
  map.grid = model.grid();
  map.max_levels = model.surfaces().max_valid_levels();
  map.done_time = std::chrono::system_clock::now();
  std::shared_ptr<const PlanningMap> planning =
      base_planning ? base_planning->WithKeepOut(std::move(keep_out))
                    : options_.make_planning(built.model, std::move(keep_out), id, terrain);
  // The terrain goes to the store only when it does not hold it yet: an edit's tiles (cut by
  // the job against a tiled base; here, from a base of whole files), or the cloud a version
  // of layout 1 passes on. It is written while the graphs are made, a core each (on a 400 m
  // site 0.03-0.08 s of a scan's 0.4 s, mostly waiting for the disk).
  std::optional<CutTerrain> tiles = std::move(built.cut);
  if (!tiles && !built.cloud.empty()) tiles = CutIntoTiles(model, built.cloud);
  TileWrites writes;
  std::future<ServiceStatus> terrain_put;  // Waited for by its destructor on every return.
  if (tiles) {
    terrain_put = std::async(std::launch::async, [&published, &id, &terrain, &tiles, &writes] {
      return published.PutTerrain(id, terrain, *tiles, &writes);
    });
  }
  // A new terrain: the robots that planned on the base here get their graphs built before the
  // version is published, so that no plan on it waits for one (a robot's first plan on a new
  // version of a site waited a second or more while its graph was built).
  double graphs_s = 0;
  const std::shared_ptr<const PlanningMap> base =
      base_planning ? nullptr : published.Held(id, current);
  if (base) {
    const auto graphs_start = SteadyClock::now();
    const auto ended = [&call] { return Ended(call); };  // Polled every grid row: no message.
    // Outside the columns an edit reassessed locally the model is the base's: the base's
    // graphs are patched there (a tenth of a build's time on a site).
    const bool local = built.edit && !built.edit->full_reassessment;
    if (planning->MakeGraphsAhead(*base, local ? &built.edit->changed_columns : nullptr,
                                  kMaxGraphsBuiltAhead, ended) > 0) {
      graphs_s = SecondsSince(graphs_start);
      if (std::optional<ServiceError> ended_now = CallEnded(call, id, current)) return *ended_now;
    }
  }
  const auto write_start = SteadyClock::now();
  if (terrain_put.valid()) {
    if (ServiceStatus put = terrain_put.get(); !put.ok()) return std::move(put).error();
  }
  // Passed again: a terrain collected since it was written is written again (PutTerrain).
  const CutTerrain* new_terrain = tiles ? &*tiles : nullptr;
  ServiceStatus put = published.PublishEdit(current, map, terrain, planning, new_terrain, nullptr);
  // Lost to a version of keep-out zones alone (its terrain the base's): the terrain made here
  // holds on it too, so it is published again with that version's zones instead of made again
  // (which cost a whole job, seconds on a site, for the same terrain).
  std::string base_terrain;
  for (int attempt = 0;
       attempt < kMaxRepublishes && !put.ok() && Has(put.error(), ServiceErrorCode::kMapChanged) &&
       request.base_version.empty() && !request.edits.empty();
       ++attempt) {
    if (base_terrain.empty()) {
      Result<std::string> known = published.TerrainOf(id, current);
      if (!known.ok() || known.value().empty()) break;
      base_terrain = std::move(known).value();
    }
    Result<MapSnapshot> now = published.Describe(id);
    if (!now.ok()) break;
    Result<std::string> now_terrain = published.TerrainOf(id, now.value().version);
    if (!now_terrain.ok() || now_terrain.value() != base_terrain) break;
    if (std::optional<ServiceError> ended = CallEnded(call, id, current)) return *ended;
    LogInfo("map_update_republished")
        .Add("map", id)
        .Add("lost_to", now.value().version)
        .Add("attempt", attempt + 1);
    current = now.value().version;
    planning = planning->WithKeepOut(name_version(now.value().keep_out, now.value().versions));
    put = published.PublishEdit(current, map, terrain, planning, new_terrain, nullptr);
  }
  if (!put.ok()) return std::move(put).error();
  MapUpdate update;
  update.write_s = SecondsSince(write_start);
  update.graphs_s = graphs_s;
  update.writes = writes;
  map.memory_bytes = planning->MemoryBytes();
  const PlanningMap* made_from = base_planning ? base_planning.get() : base.get();
  update.new_bytes = planning->MemoryBytesBeyond(made_from);
  update.map = std::move(map);
  update.edit = built.edit.value_or(EditFigures{});
  update.load_s = built.load_s;
  update.total_s = SecondsSince(start);
  return update;
}

Result<BuiltMap> MapEditor::RunEditJob(const MapEditRequest& request, const std::string& current,
                                       const CallControl& call) {
  Result<VersionFiles> files = options_.published->OpenFiles(request.id, current);
  if (!files.ok()) return std::move(files).error();
  const std::optional<OpenedTiles> base_tiles = files.value().tiles;
  MapBuildJob job;
  job.source = EditSource{std::move(files).value(), request.edits};
  job.keep_cloud = true;
  auto run = std::make_shared<EditRun>();
  AssessmentQueue::Job queued;
  queued.run = [this, run, job = std::move(job)]() mutable {
    {
      std::lock_guard lock(run->mutex);
      if (run->abandoned) {
        run->state = EditRun::State::kDone;
        return;
      }
      run->state = EditRun::State::kRunning;
    }
    run->changed.notify_all();
    const double limit_s = options_.max_assessment_time_s;
    const auto limit = limit_s > 0
                           ? SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                      std::chrono::duration<double>(limit_s))
                           : SteadyClock::time_point::max();
    std::atomic<bool> timed_out{false};
    std::atomic<bool> stopping{false};
    BuildMonitor monitor;
    monitor.should_stop = [&] {
      if (SteadyClock::now() >= limit) timed_out = true;
      if (options_.stopping && options_.stopping()) stopping = true;
      std::lock_guard lock(run->mutex);
      return run->abandoned || timed_out || stopping;
    };
    Result<BuiltMap> built = options_.build(std::move(job), monitor);
    if (!built.ok() && built.error().code == ServiceError::Code(ErrorCode::kCancelled)) {
      if (timed_out) {
        built = MakeError(ErrorCode::kDeadlineExceeded,
                          fmt::format("reassessing the edited map took longer than the server "
                                      "allows (--max-assessment-time-s {} s): edit a smaller "
                                      "region, or raise the limit",
                                      limit_s));
      } else if (stopping) {
        built = ShuttingDown();
      }
    }
    run->Finish(std::move(built));
  };
  queued.drop = [run] { run->Finish(ShuttingDown()); };
  if (!options_.queue->Post(std::move(queued))) return ShuttingDown();

  std::unique_lock lock(run->mutex);
  while (run->state != EditRun::State::kDone) {
    if (std::optional<ServiceError> ended = CallEnded(call, request.id, current)) {
      run->abandoned = true;
      // A job still queued is skipped when its turn comes; a running one stops at once (its
      // worker is killed), and the caller waits for that so its memory is free again.
      run->changed.wait(lock, [&] { return run->state != EditRun::State::kRunning; });
      return *ended;
    }
    const double left_s = WorkSecondsLeft(call.LeftSeconds());
    const auto poll = SteadyClock::now() + kCancellationPollPeriod;
    run->changed.wait_until(
        lock,
        std::isfinite(left_s)
            ? std::min(poll, SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                      std::chrono::duration<double>(left_s)))
            : poll);
  }
  Result<BuiltMap> built = std::move(*run->result);
  lock.unlock();
  if (!built.ok() || built.value().model != nullptr || !built.value().cut || !base_tiles) {
    return built;
  }
  // A cut alone (from tiles, or a map worker's): the model is the base's tiles with the cut's
  // in their place, those this replica holds of the base taken from its model.
  const auto join_start = SteadyClock::now();
  std::optional<HeldTerrain> held;
  if (std::shared_ptr<const PlanningMap> base = options_.published->Held(request.id, current)) {
    held = HeldTerrain{base->model_ptr(), base_tiles->list};
  }
  const CutTerrain& cut = *built.value().cut;
  Result<std::shared_ptr<const TerrainModel>> model =
      LoadTiledModel(OpenedTiles{base_tiles->dir, cut.list}, "of the edited version", cut.tiles,
                     held ? &*held : nullptr);
  if (!model.ok()) return std::move(model).error();
  built.value().model = std::move(model).value();
  if (built.value().edit) built.value().edit->join_s = SecondsSince(join_start);
  return built;
}

}  // namespace strata::server
