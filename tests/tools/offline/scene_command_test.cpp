// `strata-offline scene` end to end: the real binary writes a scene (at a size, for a scene that
// has one) as PCD, which LoadPointCloud reads back point for point; bad arguments get exit
// code 2, failures 1, with a message.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "run_offline.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/scenes/outdoor_site.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

using Outcome = testing::OfflineOutcome;

// Runs strata-offline with `args`, stderr merged into the output.
Outcome RunOffline(const std::string& args) { return testing::RunOffline(args, true); }

// A fresh directory per test, removed afterwards.
class SceneCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("strata_scene_command_" + std::string(info->name()) + "_" +
            std::to_string(static_cast<long long>(::getpid())));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  std::filesystem::path dir_;
};

TEST_F(SceneCommandTest, WritesTheSceneAsPcdThatLoadsBackExactly) {
  const std::string out = Path("tables.pcd");
  const Outcome run = RunOffline("scene indoor_tables --seed 3 --spacing 0.1 --out '" + out + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("indoor_tables"));
  EXPECT_THAT(run.output, HasSubstr(out));

  const PointCloud expected = GenerateIndoorTables(3, 0.1);
  auto loaded = LoadPointCloud(out);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->raw_point_count, expected.size());
  EXPECT_TRUE(loaded->points == expected) << "the binary PCD must hold the very same floats";
  EXPECT_THAT(run.output, HasSubstr(std::to_string(expected.size()) + " points"));
}

TEST_F(SceneCommandTest, DefaultsAreSeedOneAndTheScenesOwnSpacing) {
  const std::string out = Path("room.pcd");
  const Outcome run = RunOffline("scene stairs_ramp_room --out '" + out + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  auto loaded = LoadPointCloud(out);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_TRUE(loaded->points == GenerateScene("stairs_ramp_room", 1).value());
}

TEST_F(SceneCommandTest, TakesTheSizeOfASceneThatHasOne) {
  const std::string out = Path("site.pcd");
  Outcome run = RunOffline("scene outdoor_site --size 40 --spacing 0.3 --out '" + out + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("size 40 m, spacing 0.300 m"));
  auto loaded = LoadPointCloud(out);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_TRUE(loaded->points == GenerateOutdoorSite(1, 40.0, 0.3));

  run = RunOffline("scene two_level_ramp --size 40 --out '" + Path("x.pcd") + "'");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, HasSubstr("two_level_ramp has no size parameter"));
  EXPECT_FALSE(std::filesystem::exists(Path("x.pcd")));
}

TEST_F(SceneCommandTest, BadArgumentsExitWithTwo) {
  for (const std::string args :
       {"scene", "scene indoor_tables", "scene indoor_tables --out", "scene a b --out x.pcd",
        "scene indoor_tables --seed -4 --out x.pcd", "scene indoor_tables --seed 1.5 --out x.pcd",
        "scene indoor_tables --spacing fine --out x.pcd",
        "scene indoor_tables --colour red --out x.pcd"}) {
    const Outcome run = RunOffline(args);
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr("strata-offline scene: ")) << args;
  }
}

TEST_F(SceneCommandTest, FailuresExitWithOneAndSayWhy) {
  Outcome run = RunOffline("scene no_such_scene --out '" + Path("x.pcd") + "'");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, HasSubstr("INVALID_INPUT"));
  EXPECT_THAT(run.output, HasSubstr("parking_garage"));  // Lists the known scenes.

  run = RunOffline("scene indoor_tables --spacing 0.001 --out '" + Path("x.pcd") + "'");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, HasSubstr("spacing_m = 0.001"));
  EXPECT_FALSE(std::filesystem::exists(Path("x.pcd")));

  const std::string unwritable = Path("no/such/dir/x.pcd");
  run = RunOffline("scene indoor_tables --spacing 0.2 --out '" + unwritable + "'");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, HasSubstr(unwritable));
}

TEST(SavePcdTest, RoundTripsAndRefusesAnEmptyCloud) {
  const std::string path =
      (std::filesystem::temp_directory_path() /
       ("strata_save_pcd_" + std::to_string(static_cast<long long>(::getpid())) + ".pcd"))
          .string();
  const PointCloud cloud = {{0.f, 0.f, 0.f}, {1.5f, -2.25f, 1e-3f}, {-40.f, 88.f, 7.125f}};
  ASSERT_TRUE(SavePcd(cloud, path).ok());
  auto loaded = LoadPointCloud(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_TRUE(loaded->points == cloud);
  std::filesystem::remove(path);

  const Status empty = SavePcd({}, path);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(empty.error().message, HasSubstr("empty"));
}

}  // namespace
}  // namespace strata
