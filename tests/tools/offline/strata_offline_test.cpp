// The offline tool end to end: the real binary on a built-in scene, its exit codes, JSON keys
// and SVG. Each run assesses the scene again (about 0.2 s).

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "run_offline.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::EndsWith;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

using Outcome = testing::OfflineOutcome;

// Runs strata-offline with `args`; stderr is dropped unless merged.
Outcome RunOffline(const std::string& args, bool with_stderr = false) {
  return testing::RunOffline(args, with_stderr);
}

std::string Point(const Eigen::Vector3d& p) {
  std::ostringstream text;
  text << p.x() << ',' << p.y() << ',' << p.z();
  return text.str();
}

// A time budget for plans that only the sanitisers' slowness and a busy machine could reach:
// these tests check what the tool prints, never how fast it plans (the default 2 s was spent
// building the surface graph alone under ASan beside a full test run).
const std::string kPlanBudget = " --time-budget 120";

// The scene's documented start (ground floor) and goal (deck) as plan arguments.
std::string RampQuery(const Eigen::Vector3d& goal) {
  return "plan scene:two_level_ramp --threads 1" + kPlanBudget + " --start " +
         Point(GetTwoLevelRampLayout().start_example_m) + " --goal " + Point(goal);
}

nlohmann::json ParseJson(const std::string& text) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(j.is_discarded()) << "not JSON:\n" << text;
  return j;
}

void ExpectEndpoint(const nlohmann::json& endpoint, const Eigen::Vector3d& requested) {
  ASSERT_TRUE(endpoint.is_object());
  for (int i = 0; i < 3; ++i)
    EXPECT_DOUBLE_EQ(endpoint["requested"][i].get<double>(), requested(i));
  EXPECT_EQ(endpoint["snapped"].size(), 3u);
  EXPECT_GE(endpoint["level"].get<int>(), 0);
  EXPECT_GE(endpoint["distance_m"].get<double>(), 0.0);
}

// x, y, z of one JSON piece at local time t.
Eigen::Vector3d PieceValue(const nlohmann::json& piece, double t) {
  Eigen::Vector3d p;
  for (int a = 0; a < 3; ++a) {
    const nlohmann::json& c = piece["coefficients"][a];
    p(a) = 0;
    for (int k = 5; k >= 0; --k) p(a) = p(a) * t + c[k].get<double>();
  }
  return p;
}

// Within the grid column of `snapped` (default 0.2 m cells) and the verifier's default
// ground tolerance of its height.
void ExpectInSnappedColumn(const Eigen::Vector3d& p, const nlohmann::json& snapped) {
  const double cell_m = 0.2;
  EXPECT_LE(std::abs(p.x() - snapped[0].get<double>()), 0.5 * cell_m + 1e-6);
  EXPECT_LE(std::abs(p.y() - snapped[1].get<double>()), 0.5 * cell_m + 1e-6);
  EXPECT_NEAR(p.z(), snapped[2].get<double>(), 0.1);
}

TEST(StrataOfflinePlan, JsonHasEveryDocumentedKeyAndPiecesLowestOrderFirst) {
  const TwoLevelRampLayout layout = GetTwoLevelRampLayout();
  const Outcome run = RunOffline(RampQuery(layout.goal_example_m) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json j = ParseJson(run.output);

  EXPECT_EQ(j["map"], "scene:two_level_ramp");
  EXPECT_EQ(j["robot"], "differential");
  EXPECT_TRUE(j["map_seconds"].contains("load"));
  EXPECT_TRUE(j["map_seconds"].contains("assess"));
  ExpectEndpoint(j["start"], layout.start_example_m);
  ExpectEndpoint(j["goal"], layout.goal_example_m);
  EXPECT_EQ(j["goal"]["level"], 1) << "the goal is on the deck, above the ground floor";

  const nlohmann::json& stats = j["stats"];
  for (const char* key :
       {"length_m", "duration_s", "mean_curvature_per_m", "max_speed_horizontal_mps",
        "max_speed_vertical_mps", "max_accel_horizontal_mps2", "max_accel_vertical_mps2",
        "min_obstacle_distance_m", "max_ground_offset_m", "max_tilt_rad", "min_body_height_m",
        "min_headroom_m", "pieces", "search_expansions", "optimizer_iterations",
        "optimizer_attempts", "verified_samples"}) {
    EXPECT_TRUE(stats.contains(key)) << key;
  }
  for (const char* key : {"graph_s", "snap_s", "search_s", "optimize_s", "verify_s", "total_s"}) {
    EXPECT_TRUE(stats["timings"].contains(key)) << key;
  }

  const nlohmann::json& trajectory = j["trajectory"];
  EXPECT_EQ(trajectory["dimension"], 3);
  const nlohmann::json& pieces = trajectory["pieces"];
  ASSERT_FALSE(pieces.empty());
  EXPECT_EQ(pieces.size(), stats["pieces"].get<std::size_t>());
  double duration_s = 0;
  for (const nlohmann::json& piece : pieces) {
    EXPECT_GT(piece["duration_s"].get<double>(), 0.0);
    duration_s += piece["duration_s"].get<double>();
    ASSERT_EQ(piece["coefficients"].size(), 3u);
    for (const nlohmann::json& axis : piece["coefficients"]) EXPECT_EQ(axis.size(), 6u);
  }
  EXPECT_NEAR(duration_s, stats["duration_s"].get<double>(), 1e-6);
  // Lowest order first: c0 of the first piece is the start, Σ c_k T^k of the last the goal;
  // both lie in the column they snapped to (the planner keeps the requested x, y there).
  ExpectInSnappedColumn(PieceValue(pieces.front(), 0), j["start"]["snapped"]);
  const nlohmann::json& last = pieces.back();
  ExpectInSnappedColumn(PieceValue(last, last["duration_s"].get<double>()), j["goal"]["snapped"]);
}

TEST(StrataOfflinePlan, ActiveHeightRobotGetsAFourthAxis) {
  const Outcome run =
      RunOffline(RampQuery(GetTwoLevelRampLayout().goal_example_m) + " --robot biped --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json j = ParseJson(run.output);
  EXPECT_EQ(j["robot"], "biped");
  EXPECT_EQ(j["trajectory"]["dimension"], 4);
  EXPECT_EQ(j["trajectory"]["pieces"][0]["coefficients"].size(), 4u);
}

TEST(StrataOfflinePlan, TextOutputAndSvg) {
  const std::string svg_path = ::testing::TempDir() + "strata_offline_plan_test.svg";
  std::remove(svg_path.c_str());
  const Outcome run =
      RunOffline(RampQuery(GetTwoLevelRampLayout().goal_example_m) + " --svg '" + svg_path + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("level 1"));
  EXPECT_THAT(run.output, HasSubstr("pieces"));

  std::ifstream file(svg_path);
  ASSERT_TRUE(file) << "no SVG at " << svg_path;
  const std::string svg((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_THAT(svg, StartsWith("<svg xmlns=\"http://www.w3.org/2000/svg\""));
  EXPECT_THAT(svg, EndsWith("</svg>\n"));
  EXPECT_THAT(svg, HasSubstr("scene:two_level_ramp"));
  EXPECT_THAT(svg, HasSubstr("<polyline"));
}

TEST(StrataOfflinePlan, GoalOffGroundFailsWithItsReason) {
  // Level with the deck but 3 m beyond the hall's far wall: no ground within the 1 m
  // snapping tolerance.
  const TwoLevelRampLayout layout = GetTwoLevelRampLayout();
  const Eigen::Vector3d outside(layout.room_x_max_m + 3, layout.goal_example_m.y(),
                                layout.deck_z_m);

  const Outcome json = RunOffline(RampQuery(outside) + " --json");
  ASSERT_EQ(json.exit_code, 1) << json.output;
  const nlohmann::json j = ParseJson(json.output);
  ASSERT_TRUE(j.contains("error")) << json.output;
  EXPECT_EQ(j["error"]["reason"], "GOAL_OFF_GROUND");
  EXPECT_FALSE(j["error"]["message"].get<std::string>().empty());

  const Outcome text = RunOffline(RampQuery(outside), /*with_stderr=*/true);
  EXPECT_EQ(text.exit_code, 1);
  EXPECT_THAT(text.output, StartsWith("error: GOAL_OFF_GROUND: goal ("));
}

TEST(StrataOfflinePlan, BadArgumentsExitWithTwo) {
  const std::string start = Point(GetTwoLevelRampLayout().start_example_m);
  EXPECT_EQ(RunOffline("plan scene:two_level_ramp --start " + start).exit_code, 2);
  EXPECT_EQ(RunOffline("plan scene:two_level_ramp --start 1,2 --goal 1,2,3").exit_code, 2);
  EXPECT_EQ(RunOffline("plan scene:two_level_ramp --start 1,2,3 --goal 1,2,3,4").exit_code, 2);
  EXPECT_EQ(
      RunOffline("plan scene:two_level_ramp --start 1,2,3 --goal 1,2,3 --time-budget x").exit_code,
      2);
  const Outcome robot =
      RunOffline("plan scene:two_level_ramp --start 1,2,3 --goal 1,2,3 --robot tank", true);
  EXPECT_EQ(robot.exit_code, 2);
  EXPECT_THAT(robot.output, HasSubstr("differential, biped"));
}

// assess and plan share the parsing of the assessment options.
TEST(StrataOfflineAssess, ReadsTheSharedAssessmentOptions) {
  const Outcome run =
      RunOffline("assess scene:two_level_ramp --resolution 0.25 --threads 1 --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_DOUBLE_EQ(ParseJson(run.output)["grid"]["resolution_m"].get<double>(), 0.25);
  EXPECT_EQ(RunOffline("assess scene:two_level_ramp --radius").exit_code, 2);
}

TEST(StrataOffline, HelpAndMissingCommand) {
  const Outcome help = RunOffline("--help");
  ASSERT_EQ(help.exit_code, 0) << help.output;
  for (const char* command : {"assess", "plan", "scene"}) {
    EXPECT_THAT(help.output, HasSubstr(command));
  }
  EXPECT_THAT(help.output, HasSubstr("Exit codes"));

  const Outcome plan_help = RunOffline("plan --help");
  ASSERT_EQ(plan_help.exit_code, 0) << plan_help.output;
  for (const char* flag : {"--start", "--goal", "--robot", "--time-budget", "--json", "--svg",
                           "--resolution", "--radius", "--max-tilt-deg", "--threads"}) {
    EXPECT_THAT(plan_help.output, HasSubstr(flag));
  }

  const Outcome none = RunOffline("", /*with_stderr=*/true);
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_THAT(none.output, HasSubstr("strata-offline --help"));
  EXPECT_EQ(RunOffline("bench --scene stairs_ramp_room --out x").exit_code, 2)
      << "the comparison is strata-bench's now";
}

// scene:NAME without a seed is kDefaultSceneSeed's scene, the one strata-server creates for a
// CreateMap request without a seed (tests/server/scene_source_test.cpp checks the server side).
TEST(StrataOfflineAssess, SceneWithoutSeedIsTheDefaultSeedsScene) {
  const std::size_t default_points = GenerateScene("uneven_terrain", kDefaultSceneSeed)->size();
  ASSERT_NE(default_points, GenerateScene("uneven_terrain", 0)->size())
      << "the check needs seeds whose scenes differ in size";
  const Outcome run = RunOffline("assess scene:uneven_terrain --resolution 0.3 --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(ParseJson(run.output)["points"]["raw"].get<std::size_t>(), default_points);
}

TEST(StrataOfflineSavedModel, AssessSaveThenEveryCommandLoadsItWithoutAssessing) {
  const std::string path = ::testing::TempDir() + "two_level_ramp.stratamodel";
  const Outcome saved = RunOffline("assess scene:two_level_ramp --threads 1 --json --save " + path);
  ASSERT_EQ(saved.exit_code, 0) << saved.output;
  const nlohmann::json assessed = ParseJson(saved.output);
  EXPECT_FALSE(assessed["from_saved_model"].get<bool>());
  EXPECT_GT(assessed["saved"]["bytes"].get<std::size_t>(), 1000u);

  // Loaded, not assessed: the same model (figures of the assessment that made it).
  const Outcome loaded = RunOffline("assess " + path + " --json");
  ASSERT_EQ(loaded.exit_code, 0) << loaded.output;
  const nlohmann::json j = ParseJson(loaded.output);
  EXPECT_TRUE(j["from_saved_model"].get<bool>());
  EXPECT_EQ(j["memory_bytes"], assessed["memory_bytes"]);
  EXPECT_EQ(j["surfaces"], assessed["surfaces"]);
  EXPECT_EQ(j["grid"], assessed["grid"]);

  // Planning on it gives the plan the scene gives.
  const TwoLevelRampLayout layout = GetTwoLevelRampLayout();
  const std::string query = " --threads 1" + kPlanBudget + " --start " +
                            Point(layout.start_example_m) + " --goal " +
                            Point(layout.goal_example_m) + " --json";
  const Outcome from_scene = RunOffline("plan scene:two_level_ramp" + query);
  const Outcome from_file = RunOffline("plan " + path + query);
  ASSERT_EQ(from_scene.exit_code, 0) << from_scene.output;
  ASSERT_EQ(from_file.exit_code, 0) << from_file.output;
  EXPECT_EQ(ParseJson(from_file.output)["trajectory"], ParseJson(from_scene.output)["trajectory"]);

  // Options that would assess differently are refused, naming the field (a bad line: 2).
  const Outcome refused = RunOffline("assess " + path + " --resolution 0.3", true);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_THAT(refused.output, HasSubstr("grid.resolution_m"));
  EXPECT_THAT(refused.output, HasSubstr("saved model"));

  // A truncated copy is refused with the reason, exit code 1.
  const std::string truncated = ::testing::TempDir() + "truncated.stratamodel";
  {
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const Outcome broken = RunOffline("assess " + truncated, true);
  EXPECT_EQ(broken.exit_code, 1);
  EXPECT_THAT(broken.output, HasSubstr("truncated"));
}

TEST(StrataOfflineSavedModel, ProgressShowsEveryStepOnStderr) {
  const Outcome run = RunOffline("assess scene:two_level_ramp --threads 1 --progress", true);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* step : {"sorting 0%", "ground_filter 50%", "surfaces 100%", "fields 100%"}) {
    EXPECT_THAT(run.output, HasSubstr(std::string("strata-offline: assessing, ") + step));
  }
  EXPECT_THAT(RunOffline("assess scene:two_level_ramp --threads 1 --no-progress", true).output,
              Not(HasSubstr("assessing,")));
}

}  // namespace
}  // namespace strata
