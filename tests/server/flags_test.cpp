// Flags and their environment variables.
#include "flags.hpp"

#include <map>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using ::testing::HasSubstr;

FlagsOutcome Parse(std::vector<const char*> args, std::map<std::string, std::string> env = {}) {
  args.insert(args.begin(), "strata-server");
  return ParseFlags(static_cast<int>(args.size()), args.data(),
                    [env](const char* name) -> const char* {
                      const auto it = env.find(name);
                      return it == env.end() ? nullptr : it->second.c_str();
                    });
}

TEST(FlagsTest, DefaultsPreloadTheDemoScene) {
  const FlagsOutcome outcome = Parse({});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun);
  EXPECT_EQ(outcome.config.listen, "0.0.0.0:50051");
  EXPECT_EQ(outcome.config.metrics_port, 9090);
  EXPECT_TRUE(outcome.config.map_root.empty());
  ASSERT_EQ(outcome.config.preload.size(), 1u);
  EXPECT_EQ(outcome.config.preload[0].id, "demo");
  EXPECT_EQ(outcome.config.preload[0].scene_name, "two_level_ramp");
  EXPECT_EQ(outcome.config.max_concurrent_assessments, 1);
}

TEST(FlagsTest, FlagsOverrideTheEnvironment) {
  const FlagsOutcome outcome = Parse(
      {"--listen", "127.0.0.1:0", "--max-plan-time-s=2.5"},
      {{"STRATA_LISTEN", "1.2.3.4:5"}, {"STRATA_MAP_ROOT", "/maps"}, {"STRATA_METRICS_PORT", "0"}});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.error;
  EXPECT_EQ(outcome.config.listen, "127.0.0.1:0");
  EXPECT_EQ(outcome.config.map_root, "/maps");
  EXPECT_EQ(outcome.config.metrics_port, 0);
  EXPECT_DOUBLE_EQ(outcome.config.max_plan_time_s, 2.5);
}

TEST(FlagsTest, PreloadsReplaceTheDemoAndNoPreloadEmptiesTheList) {
  FlagsOutcome outcome = Parse({"--preload", "spiral=spiral0.3_2.pcd,resolution_m=0.3", "--preload",
                                "room=scene:stairs_ramp_room:7"});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.error;
  ASSERT_EQ(outcome.config.preload.size(), 2u);
  EXPECT_EQ(outcome.config.preload[0].path, "spiral0.3_2.pcd");
  EXPECT_DOUBLE_EQ(*outcome.config.preload[0].resolution_m, 0.3);
  EXPECT_EQ(outcome.config.preload[1].scene_name, "stairs_ramp_room");
  EXPECT_EQ(outcome.config.preload[1].scene_seed, 7u);

  outcome = Parse({}, {{"STRATA_PRELOAD", "a=scene:uneven_terrain b=x.pcd"}});
  ASSERT_EQ(outcome.config.preload.size(), 2u);
  EXPECT_EQ(outcome.config.preload[1].id, "b");

  outcome = Parse({"--no-preload"});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun);
  EXPECT_TRUE(outcome.config.preload.empty());
}

TEST(FlagsTest, ErrorsNameTheFlag) {
  EXPECT_THAT(Parse({"--bogus"}).error, HasSubstr("--bogus"));
  EXPECT_THAT(Parse({"--max-maps", "0"}).error, HasSubstr("--max-maps"));
  EXPECT_THAT(Parse({"--max-plan-time-s", "-1"}).error, HasSubstr("--max-plan-time-s"));
  EXPECT_THAT(Parse({"--listen"}).error, HasSubstr("needs a value"));
  EXPECT_THAT(Parse({"--preload", "nosource"}).error, HasSubstr("ID=SOURCE"));
  EXPECT_THAT(Parse({"--preload", "a=b.pcd,speed=3"}).error, HasSubstr("speed=3"));
  EXPECT_THAT(Parse({}, {{"STRATA_MAX_MAPS", "x"}}).error, HasSubstr("STRATA_MAX_MAPS"));
  EXPECT_EQ(Parse({"--help"}).action, FlagsOutcome::Action::kHelp);
}

TEST(FlagsTest, UsageListsEveryFlagWithItsVariable) {
  const std::string usage = UsageText();
  for (const char* text :
       {"--listen", "STRATA_LISTEN", "--metrics-port", "--map-root", "STRATA_MAP_ROOT", "--preload",
        "--max-concurrent-assessments", "--max-concurrent-plans", "--max-plan-time-s",
        "--shutdown-grace-s", "--keepalive-time-s"}) {
    EXPECT_THAT(usage, HasSubstr(text));
  }
}

}  // namespace
}  // namespace strata::server
