// The CLI's command line: global flags anywhere, both spellings, typed values, and the
// messages for bad ones. Parsed as main parses it, without running the command.
#include "arguments.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "commands.hpp"

namespace strata::cli {
namespace {

using ::testing::HasSubstr;

struct Parsed {
  Context ctx;
  Command run;        ///< Set when the line selects a command.
  std::string error;  ///< CLI11's message for a bad line.
  bool help = false;  ///< --help.
};

Parsed ParseStrata(std::vector<const char*> argv) {
  argv.insert(argv.begin(), "strata");
  Parsed parsed;
  CLI::App app("", "strata");
  AddStrataCommands(app, &parsed.ctx, &parsed.run);
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::CallForHelp&) {
    parsed.help = true;
  } catch (const CLI::ParseError& error) {
    parsed.error = error.what();
  }
  return parsed;
}

// The PlanRequest that `strata plan args...` would send.
v1::PlanRequest PlanRequestOf(std::vector<const char*> argv) {
  argv.insert(argv.begin(), "plan");
  CLI::App command("", "plan");
  PlanFlags flags;
  AddPlanFlags(command, &flags, /*required=*/true);
  command.parse(static_cast<int>(argv.size()), argv.data());
  return PlanRequestFromFlags(flags);
}

TEST(ArgumentsTest, GlobalFlagsGoAnywhereInEitherSpelling) {
  Parsed parsed = ParseStrata(
      {"--json", "plan", "--map=demo", "--start", "-1.5,2,0.3", "--goal", "1,1,1", "--deadline=5"});
  ASSERT_EQ(parsed.error, "");
  EXPECT_TRUE(parsed.run);
  EXPECT_TRUE(parsed.ctx.json);
  EXPECT_EQ(parsed.ctx.deadline_s, 5.0);
  EXPECT_EQ(parsed.ctx.server, "127.0.0.1:50051");

  parsed = ParseStrata({"maps", "list", "--json", "--server", "10.0.0.1:7"});
  ASSERT_EQ(parsed.error, "");
  EXPECT_TRUE(parsed.ctx.json);
  EXPECT_EQ(parsed.ctx.server, "10.0.0.1:7");

  const v1::PlanRequest request =
      PlanRequestOf({"--map=demo", "--start", "-1.5,2,0.3", "--goal=1,1,1", "--sample-dt", "0.1"});
  EXPECT_EQ(request.map_id(), "demo");
  EXPECT_EQ(request.start().position_m().x(), -1.5);  // A negative number is a value.
  EXPECT_EQ(request.start().position_m().z(), 0.3);
  EXPECT_EQ(request.goal().position_m().y(), 1.0);
  EXPECT_EQ(request.profile_name(), "differential");
  EXPECT_EQ(request.options().sample_dt_s(), 0.1);
  EXPECT_FALSE(request.options().has_time_budget_s());

  EXPECT_THAT(ParseStrata({"maps", "get", "demo", "extra"}).error, HasSubstr("extra"));
  EXPECT_TRUE(ParseStrata({"maps", "create", "--help"}).help);
  EXPECT_FALSE(ParseStrata({"maps"}).run);  // main names the commands maps takes.
}

TEST(ArgumentsTest, BadValuesAreNamed) {
  const char* kPlan[] = {"plan", "--map", "demo", "--goal", "1,2,3"};
  auto plan_with = [&](const char* flag, const char* value) {
    std::vector<const char*> argv(std::begin(kPlan), std::end(kPlan));
    argv.insert(argv.end(), {flag, value});
    return ParseStrata(argv).error;
  };
  EXPECT_THAT(plan_with("--start", "1,2"), HasSubstr("--start: must be x,y,z"));
  EXPECT_THAT(plan_with("--start", "1,2,3,4"), HasSubstr("--start: must be x,y,z"));
  EXPECT_THAT(plan_with("--start", "1,x,3"),
              HasSubstr("--start: component y must be a finite number, got \"x\""));
  EXPECT_THAT(plan_with("--start", "1,2,nan"), HasSubstr("component z must be a finite number"));
  EXPECT_THAT(plan_with("--time-budget", "inf"), HasSubstr("--time-budget: must be a finite"));
  EXPECT_THAT(ParseStrata({"setpoints", "--from", "p.json", "--dt", "abc"}).error,
              HasSubstr("--dt: must be a number > 0, got \"abc\""));
  EXPECT_THAT(ParseStrata({"setpoints", "--from", "p.json", "--steps", "0"}).error,
              HasSubstr("--steps: Value 0 not in range 1 to 1000000"));
  EXPECT_THAT(ParseStrata({"setpoints", "--from", "p.json", "--t0", "inf"}).error,
              HasSubstr("--t0: must be a finite"));
  EXPECT_THAT(ParseStrata({"setpoints", "--from", "p.json", "--map", "demo"}).error,
              HasSubstr("--from excludes --map"));
  EXPECT_THAT(ParseStrata({"--deadline", "0", "maps", "list"}).error,
              HasSubstr("--deadline: must be a number > 0"));
  EXPECT_THAT(ParseStrata({"maps", "list", "--unknown", "1"}).error, HasSubstr("--unknown"));
  EXPECT_THAT(ParseStrata({"maps", "create", "--seed", "3", "--file", "a.pcd"}).error,
              HasSubstr("--seed requires --scene"));
  EXPECT_THAT(ParseStrata({"maps", "create", "--scene", "x", "--seed", "-1"}).error,
              HasSubstr("--seed: Value -1 not in range 0 to 4294967295"));
  EXPECT_THAT(ParseStrata({"maps", "create", "x"}).error, HasSubstr("[--scene,--file]"));
  EXPECT_THAT(ParseStrata({"maps", "upload", "x", "c.pcd", "--format", "ply"}).error,
              HasSubstr("--format: ply not in {pcd,xyz,raw}"));
  EXPECT_THAT(ParseStrata({"plan", "--start", "1,2,3", "--goal", "1,2,3"}).error,
              HasSubstr("--map is required"));
  const std::string missing = ParseStrata({"plan", "--map"}).error;
  EXPECT_THAT(missing, HasSubstr("--map"));
  EXPECT_THAT(missing, HasSubstr("missing"));
}

}  // namespace
}  // namespace strata::cli
