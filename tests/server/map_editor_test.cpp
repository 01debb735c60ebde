// Edits made as the registry makes them: a job of the assessment queue under the same limit
// as new maps, bounded by the call's deadline and its cancellation, published only when the
// call still waits, and redone on the new current version when another edit overtook it.
#include "maps/map_editor.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "maps/map_registry.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

// Metadata kept in memory: the store holds a key, the table the snapshot it stands for.
class MemoryMetadata {
 public:
  std::string Encode(const MapSnapshot& map) {
    std::lock_guard lock(mutex_);
    const std::string key = "snapshot-" + std::to_string(table_.size());
    table_.emplace(key, map);
    return key;
  }
  Result<MapSnapshot> Decode(const std::string& key) {
    std::lock_guard lock(mutex_);
    const auto it = table_.find(key);
    if (it == table_.end()) return MakeError(ErrorCode::kInvalidInput, "unknown metadata " + key);
    return it->second;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, MapSnapshot> table_;
};

// An edit job that holds its slot until it is told to stop (as a long reassessment does when
// its worker is killed), counting how many run at once.
class StallingEdits {
 public:
  MapBuilder builder() {
    return [this](MapBuildJob job, const BuildMonitor& monitor) -> Result<BuiltMap> {
      if (!std::holds_alternative<EditSource>(job.source)) {
        Expected<BuiltMap> built = BuildMapHere(std::move(job), monitor);  // A new map: for real.
        if (!built) return ServiceError::FromPlanner(built.error());
        return std::move(built).value();
      }
      {
        std::lock_guard lock(mutex_);
        most_ = std::max(most_, ++running_);
        ++started_;
      }
      changed_.notify_all();
      while (!monitor.should_stop()) {
        std::unique_lock lock(mutex_);
        changed_.wait_for(lock, std::chrono::milliseconds(5));
      }
      {
        std::lock_guard lock(mutex_);
        --running_;
      }
      changed_.notify_all();
      return MakeError(ErrorCode::kCancelled, "stopped");
    };
  }
  void WaitStarted(int count) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return started_ >= count; });
  }
  int running() {
    std::lock_guard lock(mutex_);
    return running_;
  }
  int most() {
    std::lock_guard lock(mutex_);
    return most_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  int running_ = 0;
  int most_ = 0;
  int started_ = 0;
};

// Edit jobs made for real and counted, the first held until Release: edits that arrive
// meanwhile wait for it.
class HeldFirstEdit {
 public:
  MapBuilder builder() {
    return [this](MapBuildJob job, const BuildMonitor& monitor) -> Result<BuiltMap> {
      if (std::holds_alternative<EditSource>(job.source)) {
        std::unique_lock lock(mutex_);
        const int index = jobs_++;
        changed_.notify_all();
        changed_.wait(lock, [&] { return index > 0 || released_; });
      }
      Expected<BuiltMap> built = BuildMapHere(std::move(job), monitor);
      if (!built) return ServiceError::FromPlanner(built.error());
      return std::move(built).value();
    };
  }
  void WaitJobs(int count) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return jobs_ >= count; });
  }
  void Release() {
    {
      std::lock_guard lock(mutex_);
      released_ = true;
    }
    changed_.notify_all();
  }
  int jobs() {
    std::lock_guard lock(mutex_);
    return jobs_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  int jobs_ = 0;
  bool released_ = false;
};

class MapEditorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("strata_map_editor_test_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
  }
  void TearDown() override {
    registry_.reset();
    fs::remove_all(root_);
  }

  // A registry on a fresh store with `slots` assessment slots whose jobs `build` makes, and
  // map "floor" (the two-level ramp scene) created on it; returns the map's version.
  std::string StartWithFloor(int slots, MapBuilder build) {
    RegistryOptions options;
    options.assessment_threads = 1;
    options.max_concurrent_assessments = slots;
    options.build = std::move(build);
    options.store = std::move(MapStore::Open(root_).value());
    options.encode_metadata = [this](const MapSnapshot& map) { return metadata_.Encode(map); };
    options.decode_metadata = [this](const std::string& key) { return metadata_.Decode(key); };
    registry_ = std::make_unique<MapRegistry>(std::move(options));
    EXPECT_TRUE(registry_->Create("floor", SceneMapSource{"two_level_ramp", 1}, {}).ok());
    const Result<MapSnapshot> done =
        registry_->WaitUntilDone("floor", Clock::time_point::max(), {});
    EXPECT_TRUE(done.ok() && done->state == MapState::kActive);
    return done.ok() ? done->version : "";
  }

  static MapEditRequest Obstacle(double x) {
    MapEditRequest request;
    request.id = "floor";
    MapEdit edit;
    edit.region.polygon_m = {{x, 2}, {x + 1, 2}, {x + 1, 3}, {x, 3}};
    edit.region.z_min_m = -0.5;
    edit.region.z_max_m = 1;
    request.edits.push_back(edit);
    return request;
  }

  std::string Current() { return registry_->Get("floor").value().version; }

  // Waits until `count` edits of "floor" wait for the one being made; false when they do not
  // within a minute.
  bool WaitForWaitingEdits(int count) {
    const auto give_up = Clock::now() + std::chrono::minutes(1);
    while (registry_->EditsWaiting("floor") < count) {
      if (Clock::now() > give_up) return false;
      std::this_thread::yield();
    }
    return true;
  }

  fs::path root_;
  MemoryMetadata metadata_;
  std::unique_ptr<MapRegistry> registry_;
};

TEST_F(MapEditorTest, AnEditWhoseDeadlinePassesMidReassessmentLeavesTheMapAsItWas) {
  StallingEdits edits;
  const std::string before = StartWithFloor(1, edits.builder());
  CallControl call;
  call.deadline = Clock::now() + std::chrono::milliseconds(300);
  const Result<MapUpdate> update = registry_->Update(Obstacle(2), call);
  ASSERT_FALSE(update.ok());
  EXPECT_EQ(update.error().code, ServiceError::Code(ErrorCode::kDeadlineExceeded));
  EXPECT_THAT(update.error().message, HasSubstr("stays at version " + before));
  EXPECT_EQ(edits.most(), 1);     // It was under way,
  EXPECT_EQ(edits.running(), 0);  // and it stopped before the call answered.
  EXPECT_EQ(Current(), before);
  EXPECT_EQ(registry_->Get("floor").value().versions, std::vector<std::string>{before});
}

TEST_F(MapEditorTest, ACancelledEditLeavesTheMapAsItWas) {
  StallingEdits edits;
  const std::string before = StartWithFloor(1, edits.builder());
  std::atomic<bool> cancelled{false};
  CallControl call;
  call.cancelled = [&] { return cancelled.load(); };
  std::future<Result<MapUpdate>> update =
      std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), call); });
  edits.WaitStarted(1);
  cancelled = true;
  const Result<MapUpdate> ended = update.get();
  ASSERT_FALSE(ended.ok());
  EXPECT_EQ(ended.error().code, ServiceError::Code(ErrorCode::kCancelled));
  EXPECT_EQ(Current(), before);
}

// Four edits at once with one slot ran side by side on the RPC threads; now they take turns
// with each other (and with new maps). Each names its base version, so each is made alone
// (edits without one would be made in one batch).
TEST_F(MapEditorTest, ConcurrentEditsNeverRunMoreJobsAtOnceThanTheLimit) {
  for (const int slots : {1, 2}) {
    StallingEdits edits;
    const std::string base = StartWithFloor(slots, edits.builder());
    std::atomic<bool> cancelled{false};
    CallControl call;
    call.cancelled = [&] { return cancelled.load(); };
    std::vector<std::future<Result<MapUpdate>>> updates;
    for (int i = 0; i < 4; ++i) {
      updates.push_back(std::async(std::launch::async, [&, i] {
        MapEditRequest request = Obstacle(i);
        request.base_version = base;
        return registry_->Update(request, call);
      }));
    }
    edits.WaitStarted(slots);
    cancelled = true;  // Every call ends: the ones waiting are skipped, the running ones stop.
    for (auto& update : updates) EXPECT_FALSE(update.get().ok());
    EXPECT_EQ(edits.most(), slots) << slots << " slots";
    registry_.reset();
    fs::remove_all(root_);
  }
}

TEST_F(MapEditorTest, AnEditMakesTheNextVersionAsTheQueueRunsIt) {
  const std::string before = StartWithFloor(1, {});  // Jobs made here, for real.
  const Result<MapUpdate> update = registry_->Update(Obstacle(2), CallControl{});
  ASSERT_TRUE(update.ok()) << update.error().message;
  EXPECT_NE(update->map.version, before);
  EXPECT_EQ(update->map.versions, (std::vector<std::string>{update->map.version, before}));
  EXPECT_GT(update->edit.reassessed_columns, 0);
  EXPECT_EQ(Current(), update->map.version);
  // The new version's model is the one a fresh assessment of its cloud makes.
  const ActiveMap edited = registry_->GetActive("floor").value();
  Expected<LoadedCloud> cloud = strata::LoadMapSource(SceneSource{"two_level_ramp", 1});
  ASSERT_TRUE(cloud.ok());
  EXPECT_EQ(edited.map->model().summary().input_points, update->map.summary.input_points);
  EXPECT_GT(update->map.summary.input_points, cloud->points.size());
  // Against an old base version: refused, naming the current one.
  MapEditRequest stale = Obstacle(5);
  stale.base_version = before;
  const Result<MapUpdate> refused = registry_->Update(stale, CallControl{});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ServiceError::Code(ServiceErrorCode::kMapChanged));
  EXPECT_THAT(refused.error().message, HasSubstr(update->map.version));
}

// Robots sending scans faster than a version is made: the edits that arrive while one is made
// are made together, in one job, into the next version, which holds them all.
TEST_F(MapEditorTest, EditsArrivingWhileOneIsMadeAreMadeTogetherIntoTheNextVersion) {
  HeldFirstEdit edits;
  StartWithFloor(1, edits.builder());
  auto first = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), {}); });
  edits.WaitJobs(1);
  auto second = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(4), {}); });
  auto third = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(6), {}); });
  const bool waited = WaitForWaitingEdits(2);
  edits.Release();  // Before any assertion returns: the calls wait for it.
  ASSERT_TRUE(waited);
  const Result<MapUpdate> one = first.get();
  const Result<MapUpdate> two = second.get();
  const Result<MapUpdate> three = third.get();
  ASSERT_TRUE(one.ok() && two.ok() && three.ok());
  EXPECT_EQ(one->merged_updates, 1);
  EXPECT_EQ(two->merged_updates, 2);
  EXPECT_EQ(three->map.version, two->map.version);
  EXPECT_EQ(two->map.versions.at(1), one->map.version);  // Made on the first one's version.
  EXPECT_EQ(edits.jobs(), 2);
  EXPECT_EQ(Current(), two->map.version);
  // The batch's version holds both obstacles, the first one's neither: 0.3 m above each
  // block's top (z = 1 m) the nearest obstacle is the block.
  const TerrainModel& made = registry_->GetActive("floor").value().map->model();
  const TerrainModel& before = registry_->GetActive("floor", one->map.version).value().map->model();
  for (const double x : {4.5, 6.5}) {
    const Eigen::Vector3d above(x, 2.5, 1.3);
    EXPECT_NEAR(made.Distance(above), 0.3, 0.1) << x;
    EXPECT_GT(before.Distance(above), made.Distance(above) + 0.1) << x;
  }
}

// An edit that a batch cannot make fails alone; the others of its batch land.
TEST_F(MapEditorTest, AnInvalidEditInABatchFailsAloneNamingItsOwnEdit) {
  HeldFirstEdit edits;
  StartWithFloor(1, edits.builder());
  auto first = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), {}); });
  edits.WaitJobs(1);
  auto valid = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(4), {}); });
  const bool queued = WaitForWaitingEdits(1);
  MapEditRequest upside_down = Obstacle(6);
  upside_down.edits.front().region.z_min_m = 2;  // Above its z_max_m.
  auto invalid = std::async(std::launch::async, [&] { return registry_->Update(upside_down, {}); });
  const bool waited = queued && WaitForWaitingEdits(2);
  edits.Release();
  ASSERT_TRUE(waited);
  ASSERT_TRUE(first.get().ok());
  const Result<MapUpdate> landed = valid.get();
  const Result<MapUpdate> refused = invalid.get();
  ASSERT_TRUE(landed.ok()) << landed.error().message;
  EXPECT_EQ(landed->merged_updates, 1);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ServiceError::Code(ErrorCode::kInvalidInput));
  EXPECT_THAT(refused.error().message, HasSubstr("edits[0]"));
  EXPECT_EQ(Current(), landed->map.version);
}

// An edit whose call ends while it waits for its batch is dropped, and the others land.
TEST_F(MapEditorTest, AnEditCancelledWhileWaitingForItsBatchIsNotMade) {
  HeldFirstEdit edits;
  StartWithFloor(1, edits.builder());
  auto first = std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), {}); });
  edits.WaitJobs(1);
  std::atomic<bool> cancelled{false};
  CallControl call;
  call.cancelled = [&] { return cancelled.load(); };
  auto dropped =
      std::async(std::launch::async, [&] { return registry_->Update(Obstacle(6), call); });
  const bool queued = WaitForWaitingEdits(1);
  cancelled = true;
  const Result<MapUpdate> ended = dropped.get();
  edits.Release();
  ASSERT_TRUE(queued);
  ASSERT_FALSE(ended.ok());
  EXPECT_EQ(ended.error().code, ServiceError::Code(ErrorCode::kCancelled));
  EXPECT_THAT(ended.error().message, HasSubstr("its edits were not made"));
  EXPECT_EQ(registry_->EditsWaiting("floor"), 0);
  const Result<MapUpdate> one = first.get();
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(edits.jobs(), 1);
  EXPECT_EQ(Current(), one->map.version);  // No version after the first one's.
}

// A robot that planned on the base version here has its graph built on the new one before it
// is published: its first plan there waits for no graph. A map no robot planned on builds none.
TEST_F(MapEditorTest, TheGraphsOfRobotsThatPlannedAreBuiltBeforeTheVersionIsPublished) {
  StartWithFloor(1, {});
  const Result<MapUpdate> unplanned = registry_->Update(Obstacle(2), CallControl{});
  ASSERT_TRUE(unplanned.ok()) << unplanned.error().message;
  EXPECT_EQ(unplanned->graphs_s, 0);
  EXPECT_EQ(registry_->GetActive("floor").value().map->GraphCount(), 0u);

  const TraversabilityParams robot = BuiltinProfile("differential").value().Traversability();
  ASSERT_TRUE(registry_->GetActive("floor").value().map->Graph(robot).ok());
  const Result<MapUpdate> update = registry_->Update(Obstacle(4), CallControl{});
  ASSERT_TRUE(update.ok()) << update.error().message;
  EXPECT_GT(update->graphs_s, 0);
  const ActiveMap edited = registry_->GetActive("floor").value();
  EXPECT_EQ(edited.version, update->map.version);
  EXPECT_EQ(edited.map->BuiltGraphParams().size(), 1u);
}

// Keep-out zones change no terrain: they take no slot, even while the queue is busy.
TEST_F(MapEditorTest, AnEditThatLosesToZonesAloneIsPublishedOnThemWithoutBeingMadeAgain) {
  HeldFirstEdit edits;
  const std::string before = StartWithFloor(1, edits.builder());
  std::future<Result<MapUpdate>> obstacle =
      std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), CallControl{}); });
  edits.WaitJobs(1);  // Its job runs (held) on `before`.
  MapEditRequest zone;
  zone.id = "floor";
  zone.add_keep_out.push_back(Obstacle(6).edits.front().region);
  const Result<MapUpdate> zoned = registry_->Update(zone, CallControl{});
  edits.Release();  // Before any assertion: a failed one must not leave the job held.
  const Result<MapUpdate> made = obstacle.get();
  ASSERT_TRUE(zoned.ok()) << zoned.error().message;
  ASSERT_TRUE(made.ok()) << made.error().message;
  // The zone won the race; the obstacle's terrain was published on it with its zone, and its
  // job ran once.
  EXPECT_EQ(edits.jobs(), 1);
  EXPECT_EQ(Current(), made->map.version);
  EXPECT_EQ(made->map.keep_out.size(), 1u);
  EXPECT_GT(made->edit.reassessed_columns, 0);
  EXPECT_THAT(made->map.versions,
              ::testing::ElementsAre(made->map.version, zoned->map.version, before));
  EXPECT_EQ(registry_->Get("floor").value().keep_out.size(), 1u);
}

TEST_F(MapEditorTest, KeepOutZonesAloneWaitForNoSlot) {
  StallingEdits edits;
  const std::string before = StartWithFloor(1, edits.builder());
  const int levels = registry_->Get("floor").value().max_levels;
  ASSERT_GE(levels, 1);
  std::atomic<bool> cancelled{false};
  CallControl held;
  held.cancelled = [&] { return cancelled.load(); };
  std::future<Result<MapUpdate>> busy =
      std::async(std::launch::async, [&] { return registry_->Update(Obstacle(2), held); });
  edits.WaitStarted(1);
  MapEditRequest zone;
  zone.id = "floor";
  zone.add_keep_out.push_back(Obstacle(6).edits.front().region);
  const Result<MapUpdate> zoned = registry_->Update(zone, CallControl{});
  cancelled = true;
  ASSERT_TRUE(zoned.ok()) << zoned.error().message;
  EXPECT_EQ(zoned->map.keep_out.size(), 1u);
  EXPECT_NE(zoned->map.version, before);
  // The model is the base's, and so are its figures (not counted again).
  EXPECT_EQ(zoned->map.max_levels, levels);
  EXPECT_EQ(registry_->Get("floor").value().max_levels, levels);
  EXPECT_FALSE(busy.get().ok());
}

}  // namespace
}  // namespace strata::server
