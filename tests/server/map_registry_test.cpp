// The map registry without gRPC: lifecycle, errors, paging, deletion while creating, and
// concurrent use (this test also runs under ThreadSanitizer).
#include "maps/map_registry.hpp"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "held_assessment.hpp"
#include "large_floor.hpp"
#include "strata/io/saved_model.hpp"

namespace strata::server {
namespace {

using std::chrono::steady_clock;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr auto kLongWait = std::chrono::seconds(60);

// A flat 3 m x 3 m floor sampled every 5 cm: assessed in milliseconds.
PointCloud FlatFloor() {
  PointCloud cloud;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) cloud.emplace_back(0.05f * i, 0.05f * j, 0.0f);
  }
  return cloud;
}

UploadMapSource FloorSource() { return UploadMapSource{FlatFloor(), 0}; }

// A loader that blocks every load until Open() (so tests see CREATING deterministically),
// then loads for real.
class GatedLoader {
 public:
  CloudLoader loader() {
    return [this](MapSource source, const CloudLoadLimits& limits) {
      opened_.wait();
      return LoadMapSource(std::move(source), limits);
    };
  }
  void Open() { gate_.set_value(); }

 private:
  std::promise<void> gate_;
  std::shared_future<void> opened_ = gate_.get_future().share();
};

RegistryOptions Options() {
  RegistryOptions options;
  options.assessment_threads = 1;
  return options;
}

ServiceErrorCode ServerCode(const ServiceError& error) {
  return std::get<ServiceErrorCode>(error.code);
}

MapSnapshot WaitDone(const MapRegistry& registry, const std::string& id) {
  Result<MapSnapshot> done = registry.WaitUntilDone(id, steady_clock::now() + kLongWait, {});
  EXPECT_TRUE(done.ok());
  return done.ok() ? done.value() : MapSnapshot{};
}

TEST(MapRegistryTest, SceneBecomesActiveWithItsFigures) {
  MapRegistry registry(Options());
  Result<MapSnapshot> created =
      registry.Create("room", SceneMapSource{"stairs_ramp_room", 3}, AssessmentConfig{});
  ASSERT_TRUE(created.ok()) << created.error().message;
  EXPECT_EQ(created->id, "room");
  EXPECT_EQ(created->state, MapState::kCreating);

  const MapSnapshot done = WaitDone(registry, "room");
  ASSERT_EQ(done.state, MapState::kActive);
  EXPECT_EQ(done.stage, CreationStage::kDone);
  EXPECT_DOUBLE_EQ(done.progress(), 1.0);
  EXPECT_GT(done.raw_point_count, 0u);
  EXPECT_EQ(done.summary.input_points, done.raw_point_count);
  EXPECT_GT(done.summary.valid_ground_points, 0u);
  EXPECT_GT(done.grid.size.minCoeff(), 0);
  EXPECT_GT(done.memory_bytes, 0u);
  EXPECT_GE(done.max_levels, 2);  // The landing deck is over the floor's level.
  EXPECT_TRUE(done.done_time.has_value());

  Result<ActiveMap> active = registry.GetActive("room");
  ASSERT_TRUE(active.ok());
  EXPECT_EQ(active.value().map->model().grid().size, done.grid.size);
}

TEST(MapRegistryTest, CreatingMapIsNotActiveUntilAssessed) {
  GatedLoader gate;
  RegistryOptions options = Options();
  options.loader = gate.loader();
  MapRegistry registry(options);
  ASSERT_TRUE(registry.Create("floor", FloorSource(), AssessmentConfig{}).ok());

  Result<ActiveMap> active = registry.GetActive("floor");
  ASSERT_FALSE(active.ok());
  EXPECT_EQ(ServerCode(active.error()), ServiceErrorCode::kMapNotActive);
  EXPECT_THAT(active.error().message, HasSubstr("CREATING"));
  EXPECT_EQ(active.error().metadata.at("state"), "CREATING");

  // A wait that times out returns the map as it is.
  Result<MapSnapshot> early =
      registry.WaitUntilDone("floor", steady_clock::now() + std::chrono::milliseconds(20), {});
  ASSERT_TRUE(early.ok());
  EXPECT_EQ(early->state, MapState::kCreating);
  // So does one whose caller gives up.
  Result<MapSnapshot> stopped =
      registry.WaitUntilDone("floor", steady_clock::now() + kLongWait, [] { return true; });
  ASSERT_TRUE(stopped.ok());
  EXPECT_EQ(stopped->state, MapState::kCreating);

  gate.Open();
  EXPECT_EQ(WaitDone(registry, "floor").state, MapState::kActive);
  EXPECT_TRUE(registry.GetActive("floor").ok());
}

TEST(MapRegistryTest, RefusesBadIdsDuplicatesBadConfigAndTooManyMaps) {
  RegistryOptions options = Options();
  options.max_maps = 2;
  MapRegistry registry(options);

  for (const std::string id : {std::string("has space"), std::string("a/b"), std::string(65, 'x'),
                               std::string("ümlaut")}) {
    Result<MapSnapshot> bad = registry.Create(id, FloorSource(), AssessmentConfig{});
    ASSERT_FALSE(bad.ok()) << id;
    EXPECT_EQ(std::get<ErrorCode>(bad.error().code), ErrorCode::kInvalidInput);
    ASSERT_EQ(bad.error().field_violations.size(), 1u);
    EXPECT_EQ(bad.error().field_violations[0].field, "map_id");
  }

  AssessmentConfig bad_config;
  bad_config.grid.resolution_m = 0;
  Result<MapSnapshot> bad = registry.Create("a", FloorSource(), bad_config);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(std::get<ErrorCode>(bad.error().code), ErrorCode::kInvalidConfig);
  EXPECT_THAT(bad.error().message, HasSubstr("resolution_m"));

  ASSERT_TRUE(registry.Create("a", FloorSource(), AssessmentConfig{}).ok());
  Result<MapSnapshot> duplicate = registry.Create("a", FloorSource(), AssessmentConfig{});
  ASSERT_FALSE(duplicate.ok());
  EXPECT_EQ(ServerCode(duplicate.error()), ServiceErrorCode::kMapAlreadyExists);

  Result<MapSnapshot> generated = registry.Create("", FloorSource(), AssessmentConfig{});
  ASSERT_TRUE(generated.ok());
  EXPECT_THAT(generated->id, ::testing::StartsWith("map-"));

  Result<MapSnapshot> third = registry.Create("c", FloorSource(), AssessmentConfig{});
  ASSERT_FALSE(third.ok());
  EXPECT_EQ(ServerCode(third.error()), ServiceErrorCode::kTooManyMaps);

  EXPECT_EQ(ServerCode(registry.Get("nope").error()), ServiceErrorCode::kMapNotFound);
  EXPECT_EQ(ServerCode(registry.GetActive("nope").error()), ServiceErrorCode::kMapNotFound);
  EXPECT_EQ(ServerCode(registry.Delete("nope").error()), ServiceErrorCode::kMapNotFound);
}

TEST(MapRegistryTest, FailedLoadShowsTheReasonAndTheIdCanBeReused) {
  RegistryOptions options = Options();
  std::atomic<bool> fail{true};
  options.loader = [&fail](MapSource source, const CloudLoadLimits& limits) {
    if (fail) return Expected<LoadedCloud>(Error{ErrorCode::kMapLoadFailed, "truncated body"});
    return LoadMapSource(std::move(source), limits);
  };
  std::atomic<int> done_calls{0};
  {
    MapRegistry registry(options, [&done_calls](const MapSnapshot&) { ++done_calls; });
    ASSERT_TRUE(registry.Create("m", FloorSource(), AssessmentConfig{}).ok());
    const MapSnapshot failed = WaitDone(registry, "m");
    ASSERT_EQ(failed.state, MapState::kFailed);
    ASSERT_TRUE(failed.failure.has_value());
    EXPECT_EQ(std::get<ErrorCode>(failed.failure->code), ErrorCode::kMapLoadFailed);
    EXPECT_EQ(failed.failure->message, "truncated body");

    Result<ActiveMap> active = registry.GetActive("m");
    ASSERT_FALSE(active.ok());
    EXPECT_THAT(active.error().message, HasSubstr("FAILED"));
    EXPECT_THAT(active.error().message, HasSubstr("truncated body"));

    fail = false;
    ASSERT_TRUE(registry.Create("m", FloorSource(), AssessmentConfig{}).ok());
    EXPECT_EQ(WaitDone(registry, "m").state, MapState::kActive);
  }  // Destroying the registry joins its workers: every listener call has returned.
  EXPECT_EQ(done_calls.load(), 2);
}

TEST(MapRegistryTest, AMapPastItsTimeFailsWithDeadlineExceeded) {
  RegistryOptions options = Options();
  options.max_assessment_time_s = 0.05;
  MapRegistry registry(options);
  SceneMapSource site{"outdoor_site", kDefaultSceneSeed, {}};
  site.options.size_m = 200.0;  // About 2 s of assessment on one thread.
  ASSERT_TRUE(registry.Create("slow", site, AssessmentConfig{}).ok());
  const MapSnapshot failed = WaitDone(registry, "slow");
  ASSERT_EQ(failed.state, MapState::kFailed);
  ASSERT_TRUE(failed.failure.has_value());
  EXPECT_EQ(std::get<ErrorCode>(failed.failure->code), ErrorCode::kDeadlineExceeded);
  EXPECT_THAT(failed.failure->message, HasSubstr("--max-assessment-time-s 0.05 s"));
  // Without the limit, the same map is made.
  options.max_assessment_time_s = 0;
  MapRegistry unlimited(options);
  ASSERT_TRUE(unlimited.Create("floor", FloorSource(), AssessmentConfig{}).ok());
  EXPECT_EQ(WaitDone(unlimited, "floor").state, MapState::kActive);
}

TEST(MapRegistryTest, DeletingACreatingMapDiscardsItsAssessment) {
  GatedLoader gate;
  RegistryOptions options = Options();
  options.loader = gate.loader();
  std::atomic<int> done_calls{0};
  {
    MapRegistry registry(options, [&done_calls](const MapSnapshot&) { ++done_calls; });
    ASSERT_TRUE(registry.Create("gone", FloorSource(), AssessmentConfig{}).ok());
    // The worker is now blocked in the loader with "gone" (or about to take it).
    ASSERT_TRUE(registry.Delete("gone").ok());
    EXPECT_FALSE(registry.Get("gone").ok());
    gate.Open();
    EXPECT_TRUE(registry.WaitIdle(steady_clock::now() + kLongWait));
    // A new map with the same id is independent of the discarded one.
    ASSERT_TRUE(registry.Create("gone", FloorSource(), AssessmentConfig{}).ok());
    EXPECT_EQ(WaitDone(registry, "gone").state, MapState::kActive);
    const MapTotals totals = registry.Totals();
    EXPECT_EQ(totals.active, 1);
    EXPECT_EQ(totals.creating, 0);
  }  // Joins the workers: the discarded assessment never reported.
  EXPECT_EQ(done_calls.load(), 1);
}

TEST(MapRegistryTest, PlansHoldingADeletedMapKeepItAlive) {
  MapRegistry registry(Options());
  ASSERT_TRUE(registry.Create("floor", FloorSource(), AssessmentConfig{}).ok());
  ASSERT_EQ(WaitDone(registry, "floor").state, MapState::kActive);
  Result<ActiveMap> held = registry.GetActive("floor");
  ASSERT_TRUE(held.ok());
  ASSERT_TRUE(registry.Delete("floor").ok());
  EXPECT_FALSE(registry.GetActive("floor").ok());
  EXPECT_GT(held.value().map->model().summary().input_points, 0u);  // Still valid.
  EXPECT_EQ(registry.Totals().active, 0);
}

TEST(MapRegistryTest, ListsInIdOrderAPageAtATime) {
  MapRegistry registry(Options());
  for (const char* id : {"b", "a", "e", "c", "d"}) {
    ASSERT_TRUE(registry.Create(id, FloorSource(), AssessmentConfig{}).ok());
  }
  std::vector<std::string> seen;
  std::string after;
  int pages = 0;
  do {
    const MapPage page = registry.List(after, 2);
    ++pages;
    for (const MapSnapshot& map : page.maps) seen.push_back(map.id);
    after = page.last_id;
  } while (!after.empty());
  EXPECT_EQ(seen, (std::vector<std::string>{"a", "b", "c", "d", "e"}));
  EXPECT_EQ(pages, 3);
  EXPECT_TRUE(registry.List("e", 2).maps.empty());
}

TEST(MapRegistryTest, UploadCountsDroppedNonFinitePoints) {
  MapRegistry registry(Options());
  UploadMapSource upload = FloorSource();
  upload.points.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  upload.points.emplace_back(0.0f, std::numeric_limits<float>::infinity(), 0.0f);
  const std::size_t raw = upload.points.size();
  ASSERT_TRUE(registry.Create("up", std::move(upload), AssessmentConfig{}).ok());
  const MapSnapshot done = WaitDone(registry, "up");
  ASSERT_EQ(done.state, MapState::kActive);
  EXPECT_EQ(done.raw_point_count, raw);
  EXPECT_EQ(done.dropped_nonfinite_point_count, 2u);
  EXPECT_EQ(done.summary.input_points, raw - 2);
}

TEST(MapRegistryTest, ShutdownFailsQueuedMapsAndRefusesNewOnes) {
  GatedLoader gate;
  RegistryOptions options = Options();
  options.loader = gate.loader();
  MapRegistry registry(options);
  ASSERT_TRUE(registry.Create("first", FloorSource(), AssessmentConfig{}).ok());
  // Wait until the single worker holds "first", so "second" stays queued.
  while (registry.Get("first")->stage == CreationStage::kQueued) std::this_thread::yield();
  ASSERT_TRUE(registry.Create("second", FloorSource(), AssessmentConfig{}).ok());
  registry.Shutdown();
  const MapSnapshot second = registry.Get("second").value();
  EXPECT_EQ(second.state, MapState::kFailed);
  EXPECT_EQ(ServerCode(*second.failure), ServiceErrorCode::kShuttingDown);
  Result<MapSnapshot> refused = registry.Create("third", FloorSource(), AssessmentConfig{});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(ServerCode(refused.error()), ServiceErrorCode::kShuttingDown);
  EXPECT_FALSE(registry.WaitIdle(steady_clock::now() + std::chrono::milliseconds(10)));
  gate.Open();
  EXPECT_TRUE(registry.WaitIdle(steady_clock::now() + kLongWait));
  // The assessment under way when the server stopped was cancelled, not finished.
  const MapSnapshot first = registry.Get("first").value();
  EXPECT_EQ(first.state, MapState::kFailed);
  EXPECT_EQ(ServerCode(*first.failure), ServiceErrorCode::kShuttingDown);
}

// Readers and writers at once (the TSan build runs this too).
TEST(MapRegistryTest, ConcurrentCreateDeleteAndReadsStayConsistent) {
  RegistryOptions options = Options();
  options.max_concurrent_assessments = 2;
  options.max_maps = 64;
  MapRegistry registry(options);
  ASSERT_TRUE(registry.Create("stable", FloorSource(), AssessmentConfig{}).ok());
  ASSERT_EQ(WaitDone(registry, "stable").state, MapState::kActive);

  std::atomic<bool> stop{false};
  std::atomic<int> reads{0};
  std::vector<std::thread> threads;
  for (int r = 0; r < 3; ++r) {
    threads.emplace_back([&] {
      while (!stop) {
        Result<ActiveMap> map = registry.GetActive("stable");
        EXPECT_TRUE(map.ok());
        if (map.ok()) EXPECT_GT(map.value().map->MemoryBytes(), 0u);
        registry.List("", 10);
        registry.Totals();
        ++reads;
      }
    });
  }
  for (int w = 0; w < 2; ++w) {
    threads.emplace_back([&registry, w] {
      for (int i = 0; i < 10; ++i) {
        const std::string id = "w" + std::to_string(w) + "-" + std::to_string(i);
        ASSERT_TRUE(registry.Create(id, FloorSource(), AssessmentConfig{}).ok());
        if (i % 2 == 0) WaitDone(registry, id);
        ASSERT_TRUE(registry.Delete(id).ok());
      }
    });
  }
  threads[3].join();
  threads[4].join();
  stop = true;
  for (int r = 0; r < 3; ++r) threads[r].join();
  EXPECT_GT(reads.load(), 0);
  const MapTotals totals = registry.Totals();
  EXPECT_EQ(totals.active, 1);
  EXPECT_EQ(totals.creating + totals.failed, 0);
  EXPECT_EQ(registry.List("", 100).maps.size(), 1u);
}

// The assessment is held at the start of its surfaces step until its map is deleted, then let
// go: it must stop there (kCancelled) instead of finishing, whatever the machine's speed.
TEST(MapRegistryTest, AnAssessmentReportsItsStepsAndStopsWhenItsMapIsDeleted) {
  testing::HeldAssessment held(AssessmentStage::kSurfaces);
  RegistryOptions options = Options();
  options.build = held.Builder();
  MapRegistry registry(std::move(options));
  ASSERT_TRUE(registry.Create("big", testing::LargeFloorSource(), AssessmentConfig{}).ok());
  held.WaitHeld();
  // Held in its surfaces: the map shows the step and a fraction past the ground filter.
  const MapSnapshot snapshot = registry.Get("big").value();
  EXPECT_EQ(snapshot.state, MapState::kCreating);
  EXPECT_EQ(snapshot.stage, CreationStage::kAssessing);
  EXPECT_EQ(snapshot.assessment_step, AssessmentStage::kSurfaces);
  EXPECT_GT(snapshot.progress(), 0.15);
  EXPECT_LT(snapshot.progress(), 0.9);
  ASSERT_TRUE(registry.Delete("big").ok());
  held.Release();
  EXPECT_EQ(held.WaitEnded(), ErrorCode::kCancelled) << "the assessment of a deleted map went on";
  EXPECT_THAT(held.Steps(), HasSubstr("ground_filter"));
  registry.Shutdown();
  EXPECT_TRUE(registry.WaitIdle(steady_clock::now() + kLongWait));
}

TEST(MapRegistryTest, ASavedModelIsLoadedNotAssessedAndKeepsItsParameters) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("strata_registry_saved_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / "room.stratamodel";
  AssessmentConfig assessed_with;
  assessed_with.grid.resolution_m = 0.1;
  AssessmentSummary saved_summary;
  {
    Expected<LoadedCloud> cloud = strata::LoadMapSource(SceneSource{"stairs_ramp_room", 3});
    ASSERT_TRUE(cloud.ok());
    auto model = TerrainModel::Assess(cloud->points, assessed_with);
    ASSERT_TRUE(model.ok());
    ASSERT_TRUE(SaveModel(**model, path.string()).ok());
    saved_summary = (*model)->summary();
  }
  const FileMapSource source{
      OpenMapFile(std::filesystem::canonical(dir), "room.stratamodel", "f").value(),
      "room.stratamodel"};
  MapRegistry registry(Options());
  // Nothing asked: the file's parameters.
  ASSERT_TRUE(registry.Create("saved", source, AssessmentConfig{}).ok());
  const MapSnapshot done = WaitDone(registry, "saved");
  ASSERT_EQ(done.state, MapState::kActive) << done.failure->message;
  EXPECT_TRUE(done.from_saved_model);
  EXPECT_EQ(done.config.grid.resolution_m, 0.1);
  // The figures the file holds, its assessment's time among them: loaded, not assessed again.
  EXPECT_EQ(done.summary.timings.total_s, saved_summary.timings.total_s);
  EXPECT_EQ(done.summary.input_points, saved_summary.input_points);
  EXPECT_GT(done.raw_point_count, 0u);
  // The same parameters asked again: fine. Others: refused at once, naming the field.
  EXPECT_TRUE(registry.Create("again", source, assessed_with, /*config_given=*/true).ok());
  AssessmentConfig other;  // The defaults, 0.2 m, asked for explicitly.
  Result<MapSnapshot> refused = registry.Create("other", source, other, /*config_given=*/true);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(std::get<ErrorCode>(refused.error().code), ErrorCode::kInvalidConfig);
  EXPECT_THAT(refused.error().message, HasSubstr("grid.resolution_m"));
  EXPECT_THAT(refused.error().message, HasSubstr("saved model"));

  // A damaged saved model is named as the client named it, never by the server's own path.
  std::ofstream(dir / "damaged.stratamodel") << "STRATAMD" << std::string(40, '\x7f');
  const FileMapSource damaged{
      OpenMapFile(std::filesystem::canonical(dir), "damaged.stratamodel", "f").value(),
      "maps/damaged.stratamodel"};
  Result<MapSnapshot> unreadable = registry.Create("damaged", damaged, AssessmentConfig{});
  ASSERT_FALSE(unreadable.ok());
  EXPECT_THAT(unreadable.error().message, HasSubstr("maps/damaged.stratamodel"));
  EXPECT_THAT(unreadable.error().message, Not(HasSubstr(dir.string())));
  EXPECT_THAT(unreadable.error().message, Not(HasSubstr("/proc/self")));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace strata::server
