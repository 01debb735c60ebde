// The `strata` binary end to end against the real strata-server (one per test suite, on
// an ephemeral port): maps, plan, setpoints, errors and exit codes. The trajectory in the
// CLI's JSON is checked with the client library against the server's own samples.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <google/rpc/error_details.pb.h>
#include <gtest/gtest.h>

#include "server_process.hpp"
#include "strata/client/polynomial_trajectory.hpp"
#include "strata/client/setpoints.hpp"
#include "strata/v1/map_service.pb.h"
#include "strata/v1/planner_service.pb.h"
#include "strata/v1/traffic_service.pb.h"
#include "test_util/run_command.hpp"

namespace strata::client::testing {
namespace {

using server::testing::ServerProcess;
using test_util::CommandResult;
using test_util::RunCommand;
using ::testing::HasSubstr;
using ::testing::Not;

class StrataCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    server_ = ServerProcess::Start({}).release();  // Preloads the demo scene as "demo".
    ASSERT_NE(server_, nullptr);
    ASSERT_TRUE(server_->WaitServing(std::chrono::seconds(120))) << server_->Log();
    dir_ = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                     ("strata_cli_test_" + std::to_string(::getpid())));
    std::filesystem::create_directories(*dir_);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
    if (dir_ != nullptr) std::filesystem::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override { ASSERT_NE(server_, nullptr) << "strata-server did not start"; }
  void TearDown() override {
    if (HasFailure() && server_ != nullptr) {
      std::fprintf(stderr, "--- strata-server log ---\n%s\n", server_->Log().c_str());
    }
  }

  // Runs `strata --server <the test server> args...`.
  static CommandResult Strata(std::vector<std::string> args) {
    args.insert(args.begin(), {STRATA_CLI_BINARY, "--server", server_->address()});
    return RunCommand(args);
  }

  template <typename Message>
  static Message Parse(const std::string& json) {
    Message message;
    const auto status = google::protobuf::util::JsonStringToMessage(json, &message);
    EXPECT_TRUE(status.ok()) << status.ToString() << "\n" << json;
    return message;
  }

  static std::string Path(const std::string& name) { return (*dir_ / name).string(); }

  static v1::PlanResponse PlanOnDemo(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"plan",    "--map",  "demo",      "--start",
                                     "2,2,0.3", "--goal", "10,10,3.3", "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const CommandResult result = Strata(args);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return Parse<v1::PlanResponse>(result.out);
  }

  static ServerProcess* server_;
  static std::filesystem::path* dir_;
};

ServerProcess* StrataCliTest::server_ = nullptr;
std::filesystem::path* StrataCliTest::dir_ = nullptr;

double Distance(const Eigen::Vector3d& p, const v1::Vector3& q) {
  return (p - Eigen::Vector3d(q.x(), q.y(), q.z())).norm();
}

// The trajectory starts and ends exactly at the snapped states' positions.
void ExpectAt(const Eigen::Vector3d& boundary, const v1::SnappedState& snapped) {
  const v1::Vector3& q = snapped.position_m();
  EXPECT_LT((boundary - Eigen::Vector3d(q.x(), q.y(), q.z())).norm(), 1e-6);
}

TEST_F(StrataCliTest, MapsListShowsTheDemoMap) {
  const CommandResult text = Strata({"maps", "list"});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("demo"));
  EXPECT_THAT(text.out, HasSubstr("ACTIVE"));
  EXPECT_THAT(text.out, HasSubstr("scene two_level_ramp"));

  const CommandResult json = Strata({"maps", "list", "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const auto response = Parse<v1::ListMapsResponse>(json.out);
  ASSERT_EQ(response.maps_size(), 1);
  EXPECT_EQ(response.maps(0).id(), "demo");
  EXPECT_EQ(response.maps(0).state(), v1::MAP_STATE_ACTIVE);
  EXPECT_GT(response.maps(0).valid_ground_point_count(), 0u);
  // Stable keys: zero-valued fields are printed too, with proto field names.
  EXPECT_THAT(json.out, HasSubstr("\"dropped_nonfinite_point_count\""));
  EXPECT_THAT(json.out, HasSubstr("\"next_page_token\": \"\""));
}

TEST_F(StrataCliTest, ServerComesFromTheEnvironmentUnlessGiven) {
  const CommandResult from_env = RunCommand({STRATA_CLI_BINARY, "maps", "get", "demo"},
                                            {"STRATA_SERVER=" + server_->address()});
  ASSERT_EQ(from_env.exit_code, 0) << from_env.err;
  EXPECT_THAT(from_env.out, HasSubstr("map demo: ACTIVE"));
  // --server wins over the variable (which here points nowhere).
  const CommandResult flag =
      RunCommand({STRATA_CLI_BINARY, "--server", server_->address(), "maps", "get", "demo"},
                 {"STRATA_SERVER=127.0.0.1:1"});
  EXPECT_EQ(flag.exit_code, 0) << flag.err;
}

TEST_F(StrataCliTest, PlanJsonStartsAndEndsAtTheSnappedStartAndGoal) {
  const v1::PlanResponse response = PlanOnDemo({"--sample-dt", "0.1"});
  const auto trajectory = PolynomialTrajectory::FromPlanResponse(response);
  ASSERT_TRUE(trajectory.ok()) << trajectory.error().message;
  EXPECT_EQ(response.start().level(), 0u);
  EXPECT_EQ(response.goal().level(), 1u);
  ExpectAt(trajectory->PositionAt(0), response.start());
  ExpectAt(trajectory->PositionAt(trajectory->duration_s()), response.goal());
  // Where the request lay on the ground, the trajectory begins right there (x, y).
  EXPECT_NEAR(trajectory->PositionAt(0).x(), 2.0, 0.2);
  EXPECT_NEAR(trajectory->PositionAt(0).y(), 2.0, 0.2);
  EXPECT_NEAR(trajectory->duration_s(), response.stats().duration_s(), 1e-6);
  EXPECT_LT(trajectory->VelocityAt(0).norm(), 1e-6);  // Requested at rest.

  // The library's evaluation matches the server's own samples of the same trajectory.
  ASSERT_GT(response.samples_size(), 10);
  for (const v1::TrajectorySample& sample : response.samples()) {
    const TrajectoryState state = trajectory->StateAt(sample.time_s());
    EXPECT_LT(Distance(state.position_m, sample.position_m()), 1e-6) << sample.time_s();
    EXPECT_LT(Distance(state.velocity_mps, sample.velocity_mps()), 1e-6) << sample.time_s();
    EXPECT_LT(Distance(state.acceleration_mps2, sample.acceleration_mps2()), 1e-6)
        << sample.time_s();
  }
}

TEST_F(StrataCliTest, PlanSummaryNamesSnappedStatesAndPieces) {
  const CommandResult result =
      Strata({"plan", "--map", "demo", "--start", "2,2,0.3", "--goal", "10,10,3.3", "--robot",
              "differential", "--time-budget", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("plan on map demo for robot differential"));
  // Ends named as a person reads them: the ground's height, and where they are from the point
  // asked for (the per-column level index kept beside).
  EXPECT_THAT(result.out, HasSubstr("start (2.000, 2.000, 0.300) m, on the ground at 0.00 m "
                                    "(level 0 of its column), at the requested x, y"));
  EXPECT_THAT(result.out, HasSubstr("on the ground at 3.00 m (level 1 of its column)"));
  EXPECT_THAT(result.out, HasSubstr("piece   start_s  duration_s"));
}

// --via, repeated in order, with :stop to come to rest: the request carries them and the
// summary lists when each is reached (the JSON has the same times).
TEST_F(StrataCliTest, PlanThroughViasListsWhenEachIsReached) {
  const std::vector<std::string> args = {"plan",       "--map",  "demo",          "--start",
                                         "2,5.2,0.3",  "--goal", "13,8,0.3",      "--via",
                                         "9,2.75,1.7", "--via",  "10,10,3.3:stop"};
  const CommandResult result = Strata(args);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("via[0]"));
  EXPECT_THAT(result.out, HasSubstr("m pass at "));
  EXPECT_THAT(result.out, HasSubstr("via[1]"));
  EXPECT_THAT(result.out, HasSubstr("m stop at "));
  std::vector<std::string> json = args;
  json.emplace_back("--json");
  const CommandResult saved = Strata(json);
  ASSERT_EQ(saved.exit_code, 0) << saved.err;
  const auto plan = Parse<v1::PlanResponse>(saved.out);
  ASSERT_EQ(plan.via_times_s_size(), 2);
  EXPECT_GT(plan.via_times_s(1), plan.via_times_s(0));
  EXPECT_LT(plan.via_times_s(1), plan.trajectory().duration_s());
}

TEST_F(StrataCliTest, SetpointsFromASavedPlanMatchTheLibrary) {
  const CommandResult saved =
      Strata({"plan", "--map", "demo", "--start", "2,2,0.3", "--goal", "10,10,3.3", "--json"});
  ASSERT_EQ(saved.exit_code, 0) << saved.err;
  const std::string path = Path("plan.json");
  std::ofstream(path) << saved.out;
  const auto plan = Parse<v1::PlanResponse>(saved.out);
  const auto trajectory = PolynomialTrajectory::FromPlanResponse(plan);
  ASSERT_TRUE(trajectory.ok());

  // A horizon that runs past the end: the last setpoints hold the goal.
  const double t0 = trajectory->duration_s() - 1.0;
  const CommandResult result = Strata({"setpoints", "--from", path, "--t0", std::to_string(t0),
                                       "--dt", "0.25", "--steps", "8", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = Parse<google::protobuf::Struct>(result.out);
  const auto& rows = json.fields().at("setpoints").list_value().values();
  ASSERT_EQ(rows.size(), 8);
  const auto expected = ComputeSetpoints(*trajectory, std::stod(std::to_string(t0)), 0.25, 8);
  ASSERT_TRUE(expected.ok());
  for (int k = 0; k < 8; ++k) {
    const auto& row = rows[k].struct_value().fields();
    const MpcSetpoint& e = expected.value()[k];
    EXPECT_DOUBLE_EQ(row.at("time_s").number_value(), e.time_s);
    EXPECT_DOUBLE_EQ(row.at("position_m").struct_value().fields().at("x").number_value(),
                     e.position_m.x());
    EXPECT_DOUBLE_EQ(row.at("position_m").struct_value().fields().at("z").number_value(),
                     e.position_m.z());
    EXPECT_DOUBLE_EQ(row.at("yaw_rad").number_value(), e.yaw_rad);
    EXPECT_DOUBLE_EQ(row.at("yaw_rate_radps").number_value(), e.yaw_rate_radps);
    EXPECT_DOUBLE_EQ(row.at("speed_mps").number_value(), e.speed_mps);
    EXPECT_EQ(row.at("yaw_held").bool_value(), e.yaw_held);
    EXPECT_TRUE(row.at("body_height_m").has_null_value());  // Dimension 3.
  }
  const auto& last = rows[7].struct_value().fields();
  EXPECT_TRUE(last.at("yaw_held").bool_value());
  EXPECT_EQ(last.at("speed_mps").number_value(), 0.0);
  const Eigen::Vector3d end = trajectory->PositionAt(trajectory->duration_s());
  EXPECT_EQ(last.at("position_m").struct_value().fields().at("x").number_value(), end.x());
  EXPECT_EQ(last.at("position_m").struct_value().fields().at("y").number_value(), end.y());
}

TEST_F(StrataCliTest, SetpointsCanPlanThemselvesAndPrintATable) {
  const CommandResult result = Strata({"setpoints", "--map", "demo", "--start", "2,2,0.3", "--goal",
                                       "6,2,0.3", "--dt", "0.5", "--steps", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("yaw_rad"));
  EXPECT_THAT(result.out, HasSubstr("omega_radps"));
  std::size_t lines = 0;
  for (char c : result.out) lines += c == '\n';
  EXPECT_GE(lines, 6u);  // Header and five setpoints (and the held-yaw note when one is held).
}

TEST_F(StrataCliTest, UnknownMapIsNotFoundWithItsReasonAndExitCode1) {
  const CommandResult plan =
      Strata({"plan", "--map", "atlantis", "--start", "2,2,0.3", "--goal", "3,3,0.3"});
  EXPECT_EQ(plan.exit_code, 1);
  EXPECT_THAT(plan.err, HasSubstr("Plan failed: NOT_FOUND"));
  EXPECT_THAT(plan.err, HasSubstr("reason: MAP_NOT_FOUND (domain strata)"));
  EXPECT_TRUE(plan.out.empty());

  const CommandResult get = Strata({"--json", "maps", "get", "atlantis"});
  EXPECT_EQ(get.exit_code, 1);
  const auto error = Parse<google::protobuf::Struct>(get.err).fields().at("error").struct_value();
  EXPECT_EQ(error.fields().at("code").string_value(), "NOT_FOUND");
  EXPECT_EQ(error.fields().at("reason").string_value(), "MAP_NOT_FOUND");
  EXPECT_EQ(error.fields().at("rpc").string_value(), "GetMap");
}

TEST_F(StrataCliTest, OffGroundStartPrintsTheBadField) {
  const CommandResult result =
      Strata({"plan", "--map", "demo", "--start", "100,100,0.3", "--goal", "3,3,0.3"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.err, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(result.err, HasSubstr("reason: START_OFF_GROUND"));
  EXPECT_THAT(result.err, HasSubstr("bad field start.position_m"));
}

TEST_F(StrataCliTest, BadArgumentsExitWith2BeforeAnyCall) {
  const std::vector<std::vector<std::string>> cases = {
      {"plan", "--map", "demo", "--start", "1,2", "--goal", "3,3,0.3"},
      {"plan", "--start", "1,2,3", "--goal", "3,3,0.3"},
      {"plan", "--map", "demo", "--start", "1,2,3", "--goal", "3,3,0.3", "--via", "1,2:stop"},
      {"plan", "--map", "demo", "--start", "1,2,3", "--goal", "3,3,0.3", "--via", "1,2,3:halt"},
      {"frobnicate"},
      {"maps", "rename", "demo"},
      {"maps", "create", "x", "--file", "a.pcd", "--scene", "two_level_ramp"},
      {"--deadline", "0", "maps", "list"},
      {"maps", "list", "--colour", "red"},
      {"setpoints", "--from", Path("missing.json")},
      {"maps", "upload", "x", Path("cloud.ply")},
  };
  for (const auto& args : cases) {
    const CommandResult result = Strata(args);
    EXPECT_EQ(result.exit_code, 2) << args[0] << " " << result.err;
    EXPECT_THAT(result.err, HasSubstr("strata --help"));
  }
  std::ofstream(Path("bad.json")) << "{\"trajectory\": {\"dimension\": 5}}";
  const CommandResult bad_plan = Strata({"setpoints", "--from", Path("bad.json")});
  EXPECT_EQ(bad_plan.exit_code, 2);
  EXPECT_THAT(bad_plan.err, HasSubstr("invalid trajectory: dimension is 5"));
  EXPECT_EQ(RunCommand({STRATA_CLI_BINARY, "--help"}).exit_code, 0);
}

TEST_F(StrataCliTest, UnreachableServerIsAnRpcError) {
  const CommandResult result =
      RunCommand({STRATA_CLI_BINARY, "--server", "127.0.0.1:1", "--deadline", "2", "maps", "list"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.err, HasSubstr("ListMaps failed"));
}

TEST_F(StrataCliTest, CreateGetDeleteAScene) {
  const CommandResult created =
      Strata({"--deadline", "120", "maps", "create", "ramp2", "--scene", "two_level_ramp", "--seed",
              "3", "--resolution", "0.25", "--wait", "--json"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const auto map = Parse<v1::Map>(created.out);
  EXPECT_EQ(map.id(), "ramp2");
  EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE);
  EXPECT_EQ(map.source().scene().seed(), 3u);
  EXPECT_DOUBLE_EQ(map.terrain().resolution_m(), 0.25);

  const CommandResult got = Strata({"maps", "get", "ramp2"});
  ASSERT_EQ(got.exit_code, 0) << got.err;
  EXPECT_THAT(got.out, HasSubstr("map ramp2: ACTIVE"));
  EXPECT_THAT(got.out, HasSubstr("resolution 0.250 m"));

  const CommandResult again = Strata({"maps", "create", "ramp2", "--scene", "two_level_ramp"});
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_THAT(again.err, HasSubstr("ALREADY_EXISTS"));
  EXPECT_THAT(again.err, HasSubstr("MAP_ALREADY_EXISTS"));

  const CommandResult deleted = Strata({"maps", "delete", "ramp2"});
  ASSERT_EQ(deleted.exit_code, 0) << deleted.err;
  EXPECT_THAT(deleted.out, HasSubstr("deleted map ramp2"));
  const CommandResult gone = Strata({"maps", "get", "ramp2"});
  EXPECT_EQ(gone.exit_code, 1);
  EXPECT_THAT(gone.err, HasSubstr("MAP_NOT_FOUND"));
}

TEST_F(StrataCliTest, ThePreloadedDemoIsTheOfflineToolsDefaultScene) {
  // The default demo=scene:two_level_ramp, and what `strata-offline scene two_level_ramp`
  // writes without a seed, uploaded: the same points give the same count, bounds and
  // assessment, to the last bit.
  const std::string pcd = Path("two_level_ramp.pcd");
  const CommandResult written =
      RunCommand({STRATA_OFFLINE_BINARY, "scene", "two_level_ramp", "--out", pcd});
  ASSERT_EQ(written.exit_code, 0) << written.err;
  const CommandResult uploaded =
      Strata({"--deadline", "120", "maps", "upload", "offline_ramp", pcd, "--wait", "--json"});
  ASSERT_EQ(uploaded.exit_code, 0) << uploaded.err;
  const auto offline = Parse<v1::Map>(uploaded.out);
  const CommandResult got = Strata({"maps", "get", "demo", "--json"});
  ASSERT_EQ(got.exit_code, 0) << got.err;
  const auto demo = Parse<v1::Map>(got.out);
  const auto same_cloud = [](const v1::Map& a, const v1::Map& b) {
    const v1::Box3 &p = a.bounds_m(), &q = b.bounds_m();
    return a.raw_point_count() == b.raw_point_count() && p.min_m().x() == q.min_m().x() &&
           p.min_m().y() == q.min_m().y() && p.min_m().z() == q.min_m().z() &&
           p.max_m().x() == q.max_m().x() && p.max_m().y() == q.max_m().y() &&
           p.max_m().z() == q.max_m().z() &&
           a.valid_ground_point_count() == b.valid_ground_point_count() &&
           a.valid_surface_count() == b.valid_surface_count();
  };
  EXPECT_EQ(demo.source().scene().seed(), 1u);
  EXPECT_TRUE(same_cloud(demo, offline)) << got.out << "\n" << uploaded.out;

  // The fingerprint tells seeds apart: seed 0 (the demo's seed before) is another cloud.
  const CommandResult seed0 =
      Strata({"--deadline", "120", "maps", "create", "ramp_seed0", "--scene", "two_level_ramp",
              "--seed", "0", "--wait", "--json"});
  ASSERT_EQ(seed0.exit_code, 0) << seed0.err;
  const auto other = Parse<v1::Map>(seed0.out);
  EXPECT_EQ(other.source().scene().seed(), 0u);
  EXPECT_FALSE(same_cloud(demo, other));
  // Without --seed, the server's default.
  const CommandResult unseeded = Strata({"--deadline", "120", "maps", "create", "ramp_unseeded",
                                         "--scene", "two_level_ramp", "--wait", "--json"});
  ASSERT_EQ(unseeded.exit_code, 0) << unseeded.err;
  EXPECT_TRUE(same_cloud(demo, Parse<v1::Map>(unseeded.out)));

  for (const char* id : {"offline_ramp", "ramp_seed0", "ramp_unseeded"}) {
    EXPECT_EQ(Strata({"maps", "delete", id}).exit_code, 0) << id;
  }
}

TEST_F(StrataCliTest, CreatesASceneWithSizeAndSpacing) {
  const CommandResult created =
      Strata({"--deadline", "120", "maps", "create", "site", "--scene", "outdoor_site", "--size",
              "40", "--spacing", "0.25", "--wait"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  EXPECT_THAT(created.out, HasSubstr("map site: ACTIVE"));
  EXPECT_THAT(created.out, HasSubstr("scene outdoor_site:1:size_m=40:spacing_m=0.25"));
  // --wait shows the assessment's progress on stderr, from the CREATING map CreateMap returned.
  EXPECT_THAT(created.err,
              ::testing::MatchesRegex("(map site: CREATING, [a-z_]+, [0-9]+% done\n)+"));
  EXPECT_EQ(Strata({"maps", "delete", "site"}).exit_code, 0);
  // A size for a scene without one: the server names the field.
  const CommandResult sized =
      Strata({"maps", "create", "x", "--scene", "two_level_ramp", "--size", "40"});
  EXPECT_EQ(sized.exit_code, 1);
  EXPECT_THAT(sized.err, HasSubstr("bad field scene.size_m"));
  // Options without --scene are usage errors.
  EXPECT_EQ(Strata({"maps", "create", "x", "--file", "a.pcd", "--size", "40"}).exit_code, 2);
}

TEST_F(StrataCliTest, UploadStreamsAPcdInChunksAndPlansOnIt) {
  // A flat 6 m × 6 m floor at z = 0, one point every 5 cm, as binary PCD.
  std::string body;
  int count = 0;
  for (int i = 0; i <= 120; ++i) {
    for (int j = 0; j <= 120; ++j) {
      const float xyz[3] = {0.05f * i, 0.05f * j, 0.0f};
      body.append(reinterpret_cast<const char*>(xyz), sizeof(xyz));
      ++count;
    }
  }
  const std::string path = Path("floor.pcd");
  std::ofstream(path, std::ios::binary)
      << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << count
      << "\nHEIGHT 1\nPOINTS " << count << "\nDATA binary\n"
      << body;

  const CommandResult uploaded = Strata({"--deadline", "120", "maps", "upload", "floor", path,
                                         "--chunk-points", "1000", "--wait", "--json"});
  ASSERT_EQ(uploaded.exit_code, 0) << uploaded.err;
  const auto map = Parse<v1::Map>(uploaded.out);
  EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE) << map.failure().message();
  EXPECT_EQ(map.raw_point_count(), static_cast<std::uint64_t>(count));
  EXPECT_EQ(map.source().upload().received_bytes(), static_cast<std::uint64_t>(12 * count));

  const CommandResult plan =
      Strata({"plan", "--map", "floor", "--start", "1,1,0.3", "--goal", "5,4,0.3", "--json"});
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  const auto response = Parse<v1::PlanResponse>(plan.out);
  const auto trajectory = PolynomialTrajectory::FromPlanResponse(response);
  ASSERT_TRUE(trajectory.ok());
  ExpectAt(trajectory->PositionAt(trajectory->duration_s()), response.goal());
  EXPECT_NEAR(trajectory->PositionAt(trajectory->duration_s()).z(), 0.3, 0.05);  // Floor + 0.3 m.
  EXPECT_EQ(Strata({"maps", "delete", "floor"}).exit_code, 0);
}

// A server that wants TLS and tokens: the CLI reaches it with --tls-ca and STRATA_TOKEN, and
// says what is wrong without the token.
TEST_F(StrataCliTest, CostsFromOneFileOfPointsToAnother) {
  std::ofstream(Path("robots.xyz")) << "# x y z\n2 2 0.3\n8,5.25,0.3\n100 100 0\n";
  std::ofstream(Path("tasks.csv")) << "10,10,3.3\n12,9,0.3\n";
  CommandResult result =
      Strata({"costs", "--map", "demo", "--from", Path("robots.xyz"), "--to", Path("tasks.csv")});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("3 starts x 2 goals, 4 reachable"));
  EXPECT_THAT(result.out, HasSubstr("START_OFF_GROUND"));
  EXPECT_THAT(result.out, HasSubstr("unreachable: START_OFF_GROUND"));

  result = Strata({"--json", "costs", "--map", "demo", "--from", Path("robots.xyz"), "--to",
                   Path("tasks.csv")});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  const auto response = Parse<v1::EstimateCostsResponse>(result.out);
  ASSERT_EQ(response.cells_size(), 6);
  EXPECT_TRUE(response.cells(0).reachable());
  EXPECT_GT(response.cells(0).time_s(), 0);
  EXPECT_EQ(response.cells(4).reason(), "START_OFF_GROUND");

  std::ofstream(Path("empty.xyz")) << "# nothing\n";
  result =
      Strata({"costs", "--map", "demo", "--from", Path("empty.xyz"), "--to", Path("tasks.csv")});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(result.err, HasSubstr("holds no point"));
}

TEST_F(StrataCliTest, BatchPrintsEachResultAndExits1WhenOneFailed) {
  std::ofstream(Path("plans.jsonl"))
      << "# floor to deck, then a map that does not exist\n"
      << R"({"map_id":"demo","profile_name":"differential","start":{"position_m":{"x":2,"y":2,"z":0.3}},"goal":{"position_m":{"x":10,"y":10,"z":3.3}}})"
      << "\n"
      << R"({"map_id":"atlantis","profile_name":"differential","start":{"position_m":{"x":2,"y":2,"z":0.3}},"goal":{"position_m":{"x":10,"y":10,"z":3.3}}})"
      << "\n"
      << "# no robot named: the default one, as for strata plan\n"
      << R"({"map_id":"demo","start":{"position_m":{"x":2,"y":2,"z":0.3}},"goal":{"position_m":{"x":6,"y":3,"z":0.3}}})"
      << "\n";
  CommandResult result = Strata({"batch", Path("plans.jsonl")});
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_THAT(result.out, HasSubstr("plan 0 (map demo): "));
  EXPECT_THAT(result.out, HasSubstr("plan 1 (map atlantis): failed: NOT_FOUND"));
  EXPECT_THAT(result.out, HasSubstr("(MAP_NOT_FOUND)"));
  EXPECT_THAT(result.out, HasSubstr("plan 2 (map demo): "));
  EXPECT_THAT(result.out, Not(HasSubstr("no robot given")));
  EXPECT_THAT(result.err, HasSubstr("2 of 3 plans succeeded"));

  result = Strata({"--json", "batch", Path("plans.jsonl")});
  EXPECT_EQ(result.exit_code, 1);
  // The errors' details are Any messages: their types must be known to parse them back.
  ASSERT_NE(google::rpc::ErrorInfo::descriptor(), nullptr);
  ASSERT_NE(google::rpc::BadRequest::descriptor(), nullptr);
  int lines = 0, plans = 0;
  for (std::size_t at = 0, end; (end = result.out.find('\n', at)) != std::string::npos;
       at = end + 1) {
    const auto item = Parse<v1::PlanBatchResponse>(result.out.substr(at, end - at));
    ++lines;
    plans += item.has_response();
  }
  EXPECT_EQ(lines, 3);
  EXPECT_EQ(plans, 2);

  std::ofstream(Path("bad.jsonl")) << R"({"map_id":"demo","no_such_field":1})"
                                   << "\n";
  result = Strata({"batch", Path("bad.jsonl")});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(result.err, HasSubstr("line 1"));
}

TEST_F(StrataCliTest, PlansAsAFleetRobotReservesListsAndReleases) {
  CommandResult result = Strata({"plan", "--map", "demo", "--start", "3,5,0.3", "--goal",
                                 "13,10,0.3", "--robot-id", "cli-r1", "--reserve"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("fleet       robot cli-r1 waits 0.00 s"));
  EXPECT_THAT(result.out, HasSubstr("; reserved from 20"));  // An RFC 3339 time.

  result = Strata({"reservations", "list", "--map", "demo"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("1 reservation(s)"));
  EXPECT_THAT(result.out, HasSubstr("cli-r1"));
  EXPECT_THAT(result.out, HasSubstr("SEPARATION_M"));
  result = Strata({"--json", "reservations", "list", "--map", "demo"});
  const v1::Reservation listed = Parse<v1::ListReservationsResponse>(result.out).reservations(0);
  EXPECT_EQ(listed.robot_id(), "cli-r1");
  EXPECT_EQ(listed.separation_m(), 0.1);  // The plan kept the server's default.

  // A watch prints the schedule as it is, then its changes, until its deadline: exit 0.
  result = Strata({"--deadline", "2", "reservations", "watch", "--map", "demo"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("robot cli-r1 RESERVED from 20"));

  result =
      Strata({"reservations", "renew", "--map", "demo", "--robot-id", "cli-r1", "--lease", "120"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("holds its reservation on map demo until 20"));
  result =
      Strata({"reservations", "report", "--map", "demo", "--robot-id", "cli-r1", "--delay", "2.5"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("it meets 0 other robot(s)"));
  result = Strata({"reservations", "release", "--map", "demo", "--robot-id", "cli-r1"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  result = Strata({"reservations", "release", "--map", "demo", "--robot-id", "cli-r1"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.err, HasSubstr("RESERVATION_NOT_FOUND"));

  // The fleet flags are for a robot: without --robot-id nothing is sent.
  result =
      Strata({"plan", "--map", "demo", "--start", "3,5,0.3", "--goal", "13,10,0.3", "--reserve"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(result.err, HasSubstr("need --robot-id"));

  // client/README.md's replanning example: r3 drives up the ramp and follows replans; r4 comes
  // down it at once, 2 m clear of others (no passing on the ramp), and replans r3.
  result = Strata({"plan", "--map", "demo", "--start", "1,5.25,0.3", "--goal", "7,9.25,3.3",
                   "--robot-id", "cli-r3", "--reserve", "--follows-replans"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  result = Strata({"plan", "--map", "demo", "--start", "10,9.25,3.3", "--goal", "10,9.5,0.3",
                   "--robot-id", "cli-r4", "--reserve", "--max-wait", "0", "--separation", "2",
                   "--replan-robots", "1"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("robot cli-r3 replanned to let it pass"));
  result = Strata({"reservations", "release", "--map", "demo", "--robot-id", "cli-r3"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  result = Strata({"reservations", "release", "--map", "demo", "--robot-id", "cli-r4"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
}

TEST(StrataCliAccessTest, TlsAndATokenFromTheEnvironment) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("strata_cli_access_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string cert = (dir / "cert.pem").string(), key = (dir / "key.pem").string();
  const std::string tokens = (dir / "tokens").string();
  const std::string token = "cli-test-admin-token-0123";
  std::ofstream(tokens) << token << " admin\n";
  const CommandResult made =
      RunCommand({"/usr/bin/openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                  "-subj", "/CN=localhost", "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost",
                  "-keyout", key, "-out", cert});
  if (made.exit_code != 0) GTEST_SKIP() << "openssl could not make a certificate: " << made.err;
  auto server = ServerProcess::Start(
      {"--no-preload", "--tls-cert", cert, "--tls-key", key, "--auth-tokens", tokens});
  ASSERT_NE(server, nullptr);
  const std::vector<std::string> list = {
      STRATA_CLI_BINARY, "--server", server->address(), "--tls-ca", cert, "maps", "list"};
  const CommandResult with_token = RunCommand(list, {"STRATA_TOKEN=" + token});
  EXPECT_EQ(with_token.exit_code, 0) << with_token.err;
  const CommandResult without = RunCommand(list);
  EXPECT_EQ(without.exit_code, 1);
  EXPECT_THAT(without.err, HasSubstr("UNAUTHENTICATED"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace strata::client::testing
