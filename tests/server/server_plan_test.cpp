// PlannerService end to end against the real strata-server binary: plans on the demo scene
// and the spiral garage, and every documented error.
#include <algorithm>
#include <cmath>
#include <limits>

#include <gmock/gmock.h>

#include "independent_check.hpp"
#include "rpc/proto_convert.hpp"
#include "server_fixture.hpp"
#include "strata/scenes/scenes.hpp"
#include "verifier_bounds.hpp"

namespace strata::server::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

class PlannerServiceTest : public ServerFixture {};

double Distance(const v1::Vector3& a, double x, double y, double z) {
  return std::sqrt((a.x() - x) * (a.x() - x) + (a.y() - y) * (a.y() - y) +
                   (a.z() - z) * (a.z() - z));
}

// p(t) of one axis of one piece, as trajectory.proto defines it.
double Evaluate(const v1::Polynomial& polynomial, double t) {
  double value = 0;
  for (int k = polynomial.coefficients_size() - 1; k >= 0; --k) {
    value = value * t + polynomial.coefficients(k);
  }
  return value;
}

// The demo map as the server assesses it by default (--preload demo=scene:two_level_ramp: seed
// 0, the terrain parameters' defaults), for the independent check of its plans.
const TerrainModel& DemoModel() {
  static const std::shared_ptr<const TerrainModel> model =
      TerrainModel::Assess(GenerateScene("two_level_ramp", 0).value(),
                           FromProto(v1::TerrainParameters(), "terrain").value())
          .value();
  return *model;
}

// Checks what any successful plan promises: pieces as the proto describes, continuous, from
// the snapped start to the snapped goal, samples on the polynomials, stats consistent; on the
// demo map, also safe by the benchmarks' independent check (the stats are the server's own
// verifier's figures and could not catch a verifier that misses a fault).
void ExpectConsistentPlan(const v1::PlanRequest& request, const v1::PlanResponse& response) {
  const v1::Trajectory& trajectory = response.trajectory();
  ASSERT_EQ(trajectory.frame(), "map");
  ASSERT_EQ(trajectory.dimension(), 3);
  ASSERT_GT(trajectory.pieces_size(), 0);
  EXPECT_EQ(response.stats().pieces(), trajectory.pieces_size());
  double total = 0;
  for (int i = 0; i < trajectory.pieces_size(); ++i) {
    const v1::TrajectoryPiece& piece = trajectory.pieces(i);
    ASSERT_EQ(piece.axes_size(), 3);
    EXPECT_GT(piece.duration_s(), 0);
    total += piece.duration_s();
    if (i + 1 < trajectory.pieces_size()) {
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(Evaluate(piece.axes(a), piece.duration_s()),
                    Evaluate(trajectory.pieces(i + 1).axes(a), 0), 1e-6);
      }
    }
  }
  EXPECT_NEAR(trajectory.duration_s(), total, 1e-9);
  EXPECT_NEAR(response.stats().duration_s(), total, 1e-6);
  const v1::TrajectoryPiece& first = trajectory.pieces(0);
  const v1::Vector3& start = response.start().position_m();
  EXPECT_NEAR(Evaluate(first.axes(0), 0), start.x(), 1e-6);
  EXPECT_NEAR(Evaluate(first.axes(1), 0), start.y(), 1e-6);
  EXPECT_NEAR(Evaluate(first.axes(2), 0), start.z(), 1e-6);
  const v1::TrajectoryPiece& last = trajectory.pieces(trajectory.pieces_size() - 1);
  const v1::Vector3& goal = response.goal().position_m();
  EXPECT_NEAR(Evaluate(last.axes(0), last.duration_s()), goal.x(), 1e-6);
  EXPECT_NEAR(Evaluate(last.axes(1), last.duration_s()), goal.y(), 1e-6);
  EXPECT_NEAR(Evaluate(last.axes(2), last.duration_s()), goal.z(), 1e-6);
  if (request.map_id() == "demo") {
    const Result<Trajectory> returned = FromProto(trajectory);
    ASSERT_TRUE(returned.ok()) << returned.error().message;
    const Result<RobotProfile> profile = ProfileFromRequest(request);
    ASSERT_TRUE(profile.ok()) << profile.error().message;
    const bench::IndependentCheckCounts broken = bench::CheckTrajectory(
        DemoModel(), profile.value(), returned.value(), bench::CheckConfigFor(VerifierConfig{}));
    EXPECT_FALSE(broken.Any()) << "independent check: " << broken.Describe();
  }
  EXPECT_LE(response.stats().max_speed_horizontal_mps(),
            1.01 * response.profile().max_speed_horizontal_mps());
  EXPECT_GT(response.stats().length_m(), 0);
  EXPECT_GT(response.stats().timings().total_s(), 0);
  EXPECT_GT(response.time_budget_s(), 0);
}

TEST_F(PlannerServiceTest, PlansFromTheFloorOntoTheDeckOfTheDemo) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_options()->set_sample_dt_s(0.1);
  v1::PlanResponse response;
  const grpc::Status status = Plan(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(request, response);
  EXPECT_EQ(response.start().level(), 0u);
  EXPECT_EQ(response.goal().level(), 1u);
  EXPECT_LT(Distance(response.start().position_m(), 2, 2, 0.3), 0.5);
  EXPECT_EQ(response.profile().name(), "differential");
  ASSERT_GT(response.samples_size(), 2);
  EXPECT_DOUBLE_EQ(response.samples(0).time_s(), 0);
  EXPECT_DOUBLE_EQ(response.samples(response.samples_size() - 1).time_s(),
                   response.trajectory().duration_s());
  EXPECT_NEAR(response.samples(0).position_m().x(), 2, 0.2);
}

// A robot replanning on the way sends its state and the trajectory it follows: the plan
// continues that trajectory (no search) and says so; a malformed warm start is blamed by its
// field.
TEST_F(PlannerServiceTest, AReplanWithTheFollowedTrajectoryStartsWarm) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanResponse first;
  ASSERT_TRUE(Plan(PlanRequestFor("demo", 2, 5.2, 0.3, 13, 8, 0.3), &first).ok());
  EXPECT_FALSE(first.stats().warm_started());
  EXPECT_FALSE(first.stats().fallback());
  EXPECT_FALSE(first.stats().limiting_bound().empty());
  // Where the robot is 3 s in: evaluated from the response as a client would.
  const v1::Trajectory& followed = first.trajectory();
  double t = 3.0;
  int piece = 0;
  while (t > followed.pieces(piece).duration_s()) t -= followed.pieces(piece++).duration_s();
  const auto derivative = [&](int axis, int order) {
    const v1::Polynomial& p = followed.pieces(piece).axes(axis);
    double value = 0;
    for (int k = p.coefficients_size() - 1; k >= order; --k) {
      double factor = 1;
      for (int j = 0; j < order; ++j) factor *= k - j;
      value = value * t + factor * p.coefficients(k);
    }
    return value;
  };
  v1::PlanRequest replan =
      PlanRequestFor("demo", derivative(0, 0), derivative(1, 0), derivative(2, 0), 13, 8, 0.3);
  replan.mutable_start()->mutable_velocity_mps()->set_x(derivative(0, 1));
  replan.mutable_start()->mutable_velocity_mps()->set_y(derivative(1, 1));
  replan.mutable_start()->mutable_acceleration_mps2()->set_x(derivative(0, 2));
  replan.mutable_start()->mutable_acceleration_mps2()->set_y(derivative(1, 2));
  *replan.mutable_warm_start()->mutable_trajectory() = followed;
  replan.mutable_warm_start()->set_elapsed_s(3.0);
  v1::PlanResponse warm;
  const grpc::Status status = Plan(replan, &warm);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(replan, warm);
  EXPECT_TRUE(warm.stats().warm_started());
  EXPECT_EQ(warm.stats().search_expansions(), 0);
  replan.mutable_warm_start()->mutable_trajectory()->mutable_pieces(0)->set_duration_s(0);
  const grpc::Status bad = Plan(replan, &warm);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(bad.error_message(), HasSubstr("warm_start.trajectory.pieces[0].duration_s"));
}

TEST_F(PlannerServiceTest, PlansUpTheFirstTurnOfTheSpiralGarage) {
  if (!HaveSpiral()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  ASSERT_NO_FATAL_FAILURE(StartServer());
  CreateSpiral("spiral", 0.2);  // The resolution docs/benchmarks.md plans at.
  const v1::PlanRequest request = PlanRequestFor("spiral", -30, -2, 1.5, -45, -29, 5.5);
  v1::PlanResponse response;
  const grpc::Status status = Plan(request, &response, 60);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(request, response);
  // One half turn (4 m) up: the goal's ground is above the start's.
  EXPECT_GT(response.goal().position_m().z(), response.start().position_m().z() + 3);
}

// The reference query sp_ground_to_top (../shared/maps/README.md), all the way up, on the
// map assessed at 0.3 m.
TEST_F(PlannerServiceTest, PlansFromTheGroundToTheTopOfTheSpiralGarage) {
  if (!HaveSpiral()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  ASSERT_NO_FATAL_FAILURE(StartServer());
  CreateSpiral();
  v1::PlanRequest request = PlanRequestFor("spiral", -30, -2, 1.5, -30, -28, 21.5);
  request.mutable_options()->set_time_budget_s(10);
  v1::PlanResponse response;
  const grpc::Status status = Plan(request, &response, 60);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(request, response);
  EXPECT_EQ(response.start().level(), 0u);
  EXPECT_GT(response.stats().length_m(), 40);  // Up the turns of one spiral.
  EXPECT_NEAR(response.goal().position_m().z(), 21.5, 1.0);
}

// A route through a flow-through via on the ramp and a stop on the deck, back to the floor:
// the response says when each via is reached, and the trajectory, evaluated as a client
// would, is there then (at speed through the first, at rest at the stop). A via off the
// ground is blamed by its index; a route honours the time budget and the call's deadline.
TEST_F(PlannerServiceTest, PlansARouteThroughViasAndSaysWhenEachIsReached) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanRequest request = PlanRequestFor("demo", 2, 5.2, 0.3, 13, 8, 0.3);
  const auto add_via = [&](double x, double y, double z, bool stop) {
    v1::Via* via = request.add_via();
    via->mutable_position_m()->set_x(x);
    via->mutable_position_m()->set_y(y);
    via->mutable_position_m()->set_z(z);
    via->set_stop(stop);
  };
  add_via(9, 2.75, 1.7, false);  // Half-way up the ramp.
  add_via(10, 10, 3.3, true);
  v1::PlanResponse response;
  const grpc::Status status = Plan(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(request, response);
  ASSERT_EQ(response.via_times_s_size(), 2);
  EXPECT_GT(response.via_times_s(0), 0);
  EXPECT_GT(response.via_times_s(1), response.via_times_s(0));
  EXPECT_LT(response.via_times_s(1), response.trajectory().duration_s());
  // The position (order 0) or velocity (order 1) of `axis` at time t.
  const v1::Trajectory& trajectory = response.trajectory();
  const auto at = [&](double t, int axis, int order) {
    int piece = 0;
    while (piece + 1 < trajectory.pieces_size() && t > trajectory.pieces(piece).duration_s()) {
      t -= trajectory.pieces(piece++).duration_s();
    }
    const v1::Polynomial& p = trajectory.pieces(piece).axes(axis);
    double value = 0;
    for (int k = p.coefficients_size() - 1; k >= order; --k) {
      value = value * t + (order == 0 ? 1 : k) * p.coefficients(k);
    }
    return value;
  };
  const double through = response.via_times_s(0), stop = response.via_times_s(1);
  EXPECT_NEAR(at(through, 0, 0), 9, 1e-3);
  EXPECT_NEAR(at(through, 1, 0), 2.75, 1e-3);
  EXPECT_GT(std::hypot(at(through, 0, 1), at(through, 1, 1)), 0.2);
  EXPECT_NEAR(at(stop, 0, 0), 10, 0.01);
  EXPECT_NEAR(at(stop, 1, 0), 10, 0.01);
  EXPECT_NEAR(at(stop, 2, 0), 3.3, 0.15);
  EXPECT_LT(std::hypot(at(stop, 0, 1), at(stop, 1, 1), at(stop, 2, 1)), 1e-6);

  v1::PlanRequest off = request;
  off.mutable_via(1)->mutable_position_m()->set_y(-10);
  const CallError error = ErrorOf(Plan(off, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "GOAL_OFF_GROUND");
  EXPECT_THAT(error.fields, ElementsAre("via[1].position_m"));
  EXPECT_THAT(error.message, HasSubstr("via[1] ("));

  v1::PlanRequest hurried = request;
  hurried.mutable_options()->set_time_budget_s(1e-12);
  const CallError late = ErrorOf(Plan(hurried, &response));
  EXPECT_EQ(late.code, grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_EQ(late.reason, "TIME_BUDGET_EXCEEDED");
  EXPECT_EQ(Plan(request, &response, -1).error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

TEST_F(PlannerServiceTest, UnknownMapIsNotFound) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanResponse response;
  const CallError error =
      ErrorOf(Plan(PlanRequestFor("atlantis", 2, 2, 0.3, 3, 3, 0.3), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(error.reason, "MAP_NOT_FOUND");
  EXPECT_EQ(error.domain, "strata");
  EXPECT_THAT(error.fields, ElementsAre("map_id"));
}

TEST_F(PlannerServiceTest, MapStillCreatingIsNotActive) {
  ASSERT_NO_FATAL_FAILURE(
      StartServer({"--max-concurrent-assessments", "1", "--assessment-threads", "1"}));
  // Three maps queue behind each other on the single worker; the last stays CREATING for
  // the time the first two take, far longer than the Plan call below.
  for (const char* id : {"a", "b", "last"}) {
    grpc::ClientContext context;
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_scene()->set_name("uneven_terrain");
    v1::Map map;
    ASSERT_TRUE(maps_->CreateMap(&context, request, &map).ok());
  }
  v1::PlanResponse response;
  const CallError error = ErrorOf(Plan(PlanRequestFor("last", 5, 5, 1, 6, 6, 1), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(error.reason, "MAP_NOT_ACTIVE");
  EXPECT_THAT(error.message, HasSubstr("CREATING"));
}

TEST_F(PlannerServiceTest, StartOffTheGroundNamesTheNearestValidPoint) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanResponse response;
  const CallError error =
      ErrorOf(Plan(PlanRequestFor("demo", 2, -10, 0.3, 10, 10, 3.3), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "START_OFF_GROUND");
  EXPECT_THAT(error.fields, ElementsAre("start.position_m"));
  EXPECT_THAT(error.message, HasSubstr("nearest"));
}

// A square keep-out zone of the demo hall's floor storey (from below its floor to below the
// deck's ground at 3 m).
void AddFloorZone(v1::PlanRequest* request, double x_min, double y_min, double side) {
  v1::Prism* zone = request->add_keep_out();
  for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {side, 0.0}, {side, side}, {0.0, side}}) {
    v1::Vector2* corner = zone->add_polygon_m();
    corner->set_x(x_min + dx);
    corner->set_y(y_min + dy);
  }
  zone->set_z_min_m(-0.5);
  zone->set_z_max_m(2.5);
}

TEST_F(PlannerServiceTest, KeepOutZonesAreAvoidedAndAGoalInsideOneHasItsOwnReason) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  // Along the floor under the deck, y = 8 (clear of the pillars at y = 9.25); the zone
  // x, y in [9, 10] × [7.5, 8.5] lies across the straight way.
  v1::PlanRequest request = PlanRequestFor("demo", 6, 8, 0.3, 13, 8, 0.3);
  AddFloorZone(&request, 9, 7.5, 1);
  request.mutable_options()->set_sample_dt_s(0.02);
  v1::PlanResponse response;
  const grpc::Status status = Plan(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ExpectConsistentPlan(request, response);
  const double radius = response.profile().footprint_radius_m();
  for (const v1::TrajectorySample& sample : response.samples()) {
    const v1::Vector3& p = sample.position_m();
    const bool near_zone =
        p.x() > 9 - radius && p.x() < 10 + radius && p.y() > 7.5 - radius && p.y() < 8.5 + radius;
    // Outside the square grown by the footprint radius (its rounded corners included).
    const double dx = std::max({9 - p.x(), p.x() - 10, 0.0});
    const double dy = std::max({7.5 - p.y(), p.y() - 8.5, 0.0});
    EXPECT_TRUE(!near_zone || std::hypot(dx, dy) >= radius)
        << "t = " << sample.time_s() << ": (" << p.x() << ", " << p.y() << ")";
  }

  request = PlanRequestFor("demo", 6, 8, 0.3, 9.5, 8, 0.3);
  AddFloorZone(&request, 1, 1, 1);
  AddFloorZone(&request, 9, 7.5, 1);
  const CallError error = ErrorOf(Plan(request, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "GOAL_IN_KEEP_OUT");
  EXPECT_THAT(error.fields, ElementsAre("goal.position_m"));
  EXPECT_THAT(error.message, HasSubstr("keep_out[1]"));
}

TEST_F(PlannerServiceTest, AMalformedKeepOutPolygonIsBlamedByItsPath) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanRequest request = PlanRequestFor("demo", 6, 8, 0.3, 13, 8, 0.3);
  AddFloorZone(&request, 1, 1, 1);
  AddFloorZone(&request, 9, 7.5, 1);
  // Corners 1 and 2 swapped: a bow tie, its edges cross (one corner moved, so that its two
  // halves do not cancel out to no area).
  v1::Prism* zone = request.mutable_keep_out(1);
  zone->mutable_polygon_m()->SwapElements(1, 2);
  zone->mutable_polygon_m(3)->set_y(9.0);
  v1::PlanResponse response;
  CallError error = ErrorOf(Plan(request, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "INVALID_INPUT");
  EXPECT_THAT(error.fields, ElementsAre("keep_out[1].polygon_m"));
  EXPECT_THAT(error.message, HasSubstr("crosses"));

  zone->mutable_polygon_m(2)->set_y(std::numeric_limits<double>::infinity());
  error = ErrorOf(Plan(request, &response));
  EXPECT_THAT(error.fields, ElementsAre("keep_out[1].polygon_m[2].y"));
}

TEST_F(PlannerServiceTest, NonFiniteValuesAreRefusedNamingTheComponent) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  v1::PlanResponse response;
  CallError error = ErrorOf(Plan(PlanRequestFor("demo", nan, 2, 0.3, 10, 10, 3.3), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "INVALID_INPUT");
  EXPECT_THAT(error.fields, ElementsAre("start.position_m.x"));

  v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_goal()->mutable_velocity_mps()->set_z(std::numeric_limits<double>::infinity());
  error = ErrorOf(Plan(request, &response));
  EXPECT_THAT(error.fields, ElementsAre("goal.velocity_mps.z"));

  request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_profile()->set_max_tilt_rad(2.0);
  error = ErrorOf(Plan(request, &response));
  EXPECT_EQ(error.reason, "INVALID_CONFIG");
  EXPECT_THAT(error.fields, ElementsAre("profile.max_tilt_rad"));
}

TEST_F(PlannerServiceTest, ProfileTooLargeForTheMapIsAPreconditionFailure) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_profile()->set_footprint_radius_m(0.5);  // The demo was assessed for 0.3 m.
  v1::PlanResponse response;
  const CallError error = ErrorOf(Plan(request, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(error.reason, "PROFILE_MISMATCH");
  EXPECT_THAT(error.fields, ElementsAre("profile.footprint_radius_m"));
}

TEST_F(PlannerServiceTest, TimeBudgetExceededIsReportedWithItsReason) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  // A budget below the clock's resolution: the plan's deadline is its start, so it has passed
  // at the plan's first poll on any machine.
  v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_options()->set_time_budget_s(1e-12);
  v1::PlanResponse response;
  const CallError error = ErrorOf(Plan(request, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_EQ(error.reason, "TIME_BUDGET_EXCEEDED");
  EXPECT_THAT(error.message, HasSubstr("time budget"));

  // A call whose deadline has already passed ends with DEADLINE_EXCEEDED, whoever notices.
  request.mutable_options()->clear_time_budget_s();
  EXPECT_EQ(Plan(request, &response, -1).error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

}  // namespace
}  // namespace strata::server::testing
