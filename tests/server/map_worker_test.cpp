// Maps made in the real strata-map-worker process (map_worker.hpp): the same model as on the
// registry's own thread, and every way a worker can end badly (an error, a crash, its memory
// or CPU limit, being stopped) failing that map with its own reason.
#include "maps/map_worker.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "maps/map_store.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/prism.hpp"
#include "test_util/model_bytes.hpp"
#include "test_util/time_scale.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// The processes this test process started and has not reaped yet.
std::vector<pid_t> ChildProcesses() {
  std::vector<pid_t> children;
  for (const fs::directory_entry& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream list(task.path() / "children");
    for (pid_t pid = 0; list >> pid;) children.push_back(pid);
  }
  return children;
}

class MapWorkerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scratch_ = fs::temp_directory_path() /
               ("map_worker_test_" + std::to_string(getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(scratch_);
    options_.program = STRATA_MAP_WORKER_BINARY;
    options_.scratch_dir = scratch_;
  }
  void TearDown() override {
    // Every job's directory is gone, whatever the job's end.
    EXPECT_TRUE(fs::is_empty(scratch_)) << scratch_;
    fs::remove_all(scratch_);
  }

  static MapBuildJob SceneJob(const std::string& name, std::optional<double> size_m = {}) {
    MapBuildJob job;
    SceneMapSource scene{name, kDefaultSceneSeed, {}};
    scene.options.size_m = size_m;
    job.source = scene;
    job.config.num_threads = 2;
    return job;
  }

  Result<BuiltMap> Build(MapBuildJob job, const BuildMonitor& monitor = {}) {
    return MapWorkerBuilder(options_)(std::move(job), monitor);
  }

  fs::path scratch_;
  MapWorkerOptions options_;
};

ErrorCode CodeOf(const ServiceError& error) {
  const auto* code = std::get_if<ErrorCode>(&error.code);
  return code != nullptr ? *code : ErrorCode::kInvalidInput;
}

// The same model, byte for byte but for the timings, and the same version.
void ExpectSameMap(const BuiltMap& there, const BuiltMap& here) {
  const std::string there_bytes = test_util::BytesWithoutTimings(*there.model);
  const std::string here_bytes = test_util::BytesWithoutTimings(*here.model);
  EXPECT_TRUE(there_bytes == here_bytes)
      << "first difference at byte " << test_util::FirstDifferingByte(there_bytes, here_bytes);
  EXPECT_EQ(there.version, here.version);
}

// A worker's allocator backs its large blocks with huge pages, unless the server's
// environment tunes glibc itself: that choice is the operator's.
TEST(WorkerEnvironmentTest, AsksForHugePagesUnlessGlibcIsTunedAlready) {
  std::string path = "PATH=/usr/bin";
  std::string tuned = "GLIBC_TUNABLES=glibc.malloc.arena_max=2";
  std::vector<char*> plain = {path.data(), nullptr};
  EXPECT_THAT(WorkerEnvironment(plain.data()),
              ::testing::ElementsAre("PATH=/usr/bin", "GLIBC_TUNABLES=glibc.malloc.hugetlb=1"));
  std::vector<char*> operators = {tuned.data(), path.data(), nullptr};
  EXPECT_THAT(WorkerEnvironment(operators.data()),
              ::testing::ElementsAre("GLIBC_TUNABLES=glibc.malloc.arena_max=2", "PATH=/usr/bin"));
}

TEST_F(MapWorkerTest, MakesTheModelTheRegistrysOwnThreadWould) {
  int loaded_calls = 0;
  std::set<AssessmentStage> steps;
  bool fractions_in_range = true;
  BuildMonitor monitor;
  monitor.on_loaded = [&](std::size_t, std::size_t, double) { ++loaded_calls; };
  monitor.on_progress = [&](AssessmentStage step, double fraction) {
    steps.insert(step);
    fractions_in_range = fractions_in_range && fraction >= 0 && fraction <= 1;
  };
  Result<BuiltMap> there = Build(SceneJob("two_level_ramp"), monitor);
  ASSERT_TRUE(there.ok()) << there.error().message;
  Expected<BuiltMap> here = BuildMapHere(SceneJob("two_level_ramp"), {});
  ASSERT_TRUE(here.ok()) << here.error().message;

  ExpectSameMap(*there, *here);
  EXPECT_EQ(there->raw_point_count, here->raw_point_count);
  EXPECT_GT(there->raw_point_count, 0u);
  EXPECT_GT(there->load_s, 0.0);
  EXPECT_EQ(loaded_calls, 1);
  // Every step reported its progress through the pipe.
  EXPECT_EQ(steps.size(), 4u);
  EXPECT_TRUE(fractions_in_range);
  EXPECT_TRUE(there->cloud.empty());  // Not asked for.
}

// An edit of a tiled version: the worker hands back only the tiles the edit changed (the
// issue's "loading a version loads only the tiles a replica does not already hold"), and the
// server joins the same model the registry's own thread makes, with the same cut.
TEST_F(MapWorkerTest, AnEditOfATiledVersionHandsBackOnlyTheTilesItChanged) {
  const fs::path store_root = scratch_.string() + "_store";
  {
    Result<std::unique_ptr<MapStore>> opened = MapStore::Open(store_root);
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    MapStore& store = *opened.value();
    MapBuildJob made = SceneJob("parking_garage");
    made.keep_cloud = true;
    Expected<BuiltMap> base = BuildMapHere(std::move(made), {});
    ASSERT_TRUE(base.ok()) << base.error().message;
    ASSERT_TRUE(store.PutTerrain("g", base->version, CutIntoTiles(*base->model, base->cloud)).ok());
    ASSERT_TRUE(store.PutVersion("g", base->version, base->version, "{}").ok());
    ASSERT_TRUE(store.PublishNew("g", base->version).ok());
    const auto edit_job = [&] {
      MapBuildJob job;
      Result<VersionFiles> files = store.OpenVersion("g", base->version);
      EXPECT_TRUE(files.ok() && files.value().tiles);
      const Prism box =
          BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(6, 6, 0), Eigen::Vector3d(8, 8, 1)));
      job.source = EditSource{std::move(files).value(), {{MapEdit::Kind::kAddObstacle, box}}};
      job.keep_cloud = true;
      return job;
    };
    Result<BuiltMap> there = Build(edit_job());
    ASSERT_TRUE(there.ok()) << there.error().message;
    Expected<BuiltMap> here = BuildMapHere(edit_job(), {});
    ASSERT_TRUE(here.ok()) << here.error().message;
    // Made from the tiles around the obstacle: a cut, whose model the caller joins.
    ASSERT_TRUE(there->edit && here->edit);
    EXPECT_TRUE(there->edit->from_tiles);
    EXPECT_TRUE(here->edit->from_tiles);
    EXPECT_EQ(there->model, nullptr);
    EXPECT_EQ(here->model, nullptr);
    const std::optional<OpenedTiles> base_tiles =
        std::get<EditSource>(edit_job().source).files.tiles;
    ASSERT_TRUE(base_tiles);
    for (BuiltMap* built : {&there.value(), &*here}) {
      ASSERT_TRUE(built->cut);
      Result<std::shared_ptr<const TerrainModel>> model = LoadTiledModel(
          OpenedTiles{base_tiles->dir, built->cut->list}, "edited", built->cut->tiles);
      ASSERT_TRUE(model.ok()) << model.error().message;
      built->model = std::move(model).value();
    }
    ExpectSameMap(*there, *here);
    // The same tiles, but the header's, which holds the reassessment's timings.
    ASSERT_TRUE(there->cut && here->cut);
    EXPECT_EQ(there->cut->list.model, here->cut->list.model);
    EXPECT_EQ(there->cut->list.cloud, here->cut->list.cloud);
    const auto names = [](const CutTerrain& cut) {
      std::set<std::string> held;
      for (const auto& [name, bytes] : cut.tiles) held.insert(name);
      held.erase(cut.list.header);
      return held;
    };
    EXPECT_EQ(names(*there->cut), names(*here->cut));
    // The header and the few model and cloud tiles around the obstacle, of hundreds.
    EXPECT_GE(there->cut->tiles.size(), 3u);
    EXPECT_LE(there->cut->tiles.size(), 9u);
    EXPECT_GT(there->cut->list.model.size(), 10u);
    EXPECT_TRUE(there->cloud.empty());  // The cut holds what the store writes.
    EXPECT_EQ(there->edit->cloud_points, here->edit->cloud_points);
    EXPECT_GT(there->edit->cloud_points, base->cloud.size());
  }
  fs::remove_all(store_root);
}

TEST_F(MapWorkerTest, UploadedPointsKeepTheirCountsAndComeBackSanitised) {
  UploadMapSource upload;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) upload.points.emplace_back(0.05f * i, 0.05f * j, 0.0f);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  upload.points.emplace_back(nan, 0.0f, 0.0f);
  upload.points.emplace_back(1.0f, std::numeric_limits<float>::infinity(), 0.0f);
  MapBuildJob job;
  job.source = upload;
  job.keep_cloud = true;
  Result<BuiltMap> there = Build(job);
  ASSERT_TRUE(there.ok()) << there.error().message;
  Expected<BuiltMap> here = BuildMapHere(job, {});
  ASSERT_TRUE(here.ok()) << here.error().message;

  EXPECT_EQ(there->raw_point_count, 3602u);
  EXPECT_EQ(there->dropped_nonfinite, 2u);
  EXPECT_EQ(there->cloud, here->cloud);
  EXPECT_EQ(there->cloud.size(), 3600u);
  EXPECT_EQ(there->version, here->version);
  EXPECT_TRUE(test_util::BytesWithoutTimings(*there->model) ==
              test_util::BytesWithoutTimings(*here->model));
}

TEST_F(MapWorkerTest, AReadersErrorIsTheMapsError) {
  const fs::path broken = scratch_.parent_path() / ("broken_" + std::to_string(getpid()) + ".pcd");
  std::ofstream(broken) << "VERSION 0.7\nFIELDS x y z\nPOINTS 5\nDATA ascii\n1 2 3\n";
  MapBuildJob job;
  // The worker reads the file the server opened, and names it as the client did.
  job.source = FileMapSource{
      OpenMapFile(fs::canonical(broken.parent_path()), broken.filename().string(), "f").value(),
      "broken.pcd"};
  Result<BuiltMap> built = Build(job);
  fs::remove(broken);
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kMapLoadFailed);
  EXPECT_THAT(built.error().message, HasSubstr("broken.pcd"));
  EXPECT_THAT(built.error().message, Not(HasSubstr(broken.parent_path().string())));
}

TEST_F(MapWorkerTest, ACrashFailsTheMapNamingTheSignalAndTheStep) {
  BuildMonitor monitor;
  // Once the points are read, the worker dies as a reader or an assessment would on a bug.
  monitor.on_loaded = [](std::size_t, std::size_t, double) {
    for (const pid_t child : ChildProcesses()) kill(child, SIGSEGV);
  };
  Result<BuiltMap> built = Build(SceneJob("outdoor_site", 200.0), monitor);
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kMapLoadFailed);
  EXPECT_THAT(built.error().message, HasSubstr("crashed (SIGSEGV"));
  EXPECT_THAT(built.error().message, HasSubstr("while assessing the terrain"));
  EXPECT_THAT(built.error().message, HasSubstr("the server is unaffected"));
}

// A SIGKILL the server did not send was reported as "needed more memory than a map may use",
// which an operator's kill is not: the message says what is known, the signal and the limit.
TEST_F(MapWorkerTest, AKillFromOutsideIsReportedAsSuch) {
  BuildMonitor monitor;
  monitor.on_loaded = [](std::size_t, std::size_t, double) {
    for (const pid_t child : ChildProcesses()) kill(child, SIGKILL);
  };
  Result<BuiltMap> built = Build(SceneJob("outdoor_site", 200.0), monitor);
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kResourceExhausted);
  EXPECT_THAT(built.error().message, HasSubstr("killed by signal 9 (SIGKILL)"));
  EXPECT_THAT(built.error().message, HasSubstr("not by this server"));
  EXPECT_THAT(built.error().message, HasSubstr("--max-assessment-memory 4096 MiB"));
  EXPECT_THAT(built.error().message, Not(HasSubstr("needed more memory")));
}

TEST_F(MapWorkerTest, MemoryBeyondTheLimitIsResourceExhausted) {
  options_.memory_bytes = 64 << 20;  // The 200 m site needs about 220 MB.
  Result<BuiltMap> built = Build(SceneJob("outdoor_site", 200.0));
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kResourceExhausted) << built.error().message;
  EXPECT_THAT(built.error().message, HasSubstr("--max-assessment-memory 64 MiB"));
}

TEST_F(MapWorkerTest, CpuTimeBeyondTheLimitIsResourceExhausted) {
  // The 400 m site takes about 8 s of CPU time (the 200 m one 2 s, in a Release build on the
  // CI machine): a machine several times faster still meets the limit of 1 s.
  options_.cpu_s = 1;
  Result<BuiltMap> built = Build(SceneJob("outdoor_site", 400.0));
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kResourceExhausted) << built.error().message;
  EXPECT_THAT(built.error().message, HasSubstr("1 s of CPU time"));
}

TEST_F(MapWorkerTest, StoppingKillsTheWorkerAtOnce) {
  std::atomic<bool> stop{false};
  BuildMonitor monitor;
  // The worker is frozen (SIGSTOP) before the stop is asked for: it can neither finish nor
  // notice anything, so Build returns only if the worker is killed, whatever the machine's
  // speed. A stop that waited for the worker would hang here (and fail on the test timeout).
  monitor.on_loaded = [&](std::size_t, std::size_t, double) {
    for (const pid_t child : ChildProcesses()) kill(child, SIGSTOP);
    stop = true;
  };
  monitor.should_stop = [&] { return stop.load(); };
  Result<BuiltMap> built = Build(SceneJob("outdoor_site", 200.0), monitor);
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(CodeOf(built.error()), ErrorCode::kCancelled);
  EXPECT_TRUE(ChildProcesses().empty());  // Killed and reaped.
}

TEST_F(MapWorkerTest, AMissingProgramIsAClearError) {
  options_.program = scratch_ / "no-such-worker";
  Result<BuiltMap> built = Build(SceneJob("two_level_ramp"));
  ASSERT_FALSE(built.ok());
  EXPECT_THAT(built.error().message, HasSubstr("cannot start the map worker"));
  EXPECT_THAT(built.error().message, HasSubstr("no-such-worker"));
}

}  // namespace
}  // namespace strata::server
