#include "strata/planner.hpp"

#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "independent_check.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "test_util/hand_made_maps.hpp"
#include "test_util/terrain_queries.hpp"
#include "test_util/time_scale.hpp"
#include "verifier_bounds.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::shared_ptr<const TerrainModel> Assess(const PointCloud& cloud, double resolution_m) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  return TerrainModel::Assess(cloud, config).value();
}

PlanRequest Request(const Eigen::Vector3d& start, const Eigen::Vector3d& goal,
                    const std::string& robot = "differential") {
  PlanRequest request;
  request.start.position_m = start;
  request.goal.position_m = goal;
  request.profile = BuiltinProfile(robot).value();
  // The product's budget, in the time of this build (a sanitised one runs several times slower).
  request.options.time_budget_s *= test_util::kTimeScale;
  return request;
}

// Properties every successful plan must have, whatever the map.
void ExpectSound(const PlanningMap& map, const PlanResult& plan, const PlanRequest& request) {
  const Trajectory& t = plan.trajectory;
  ASSERT_FALSE(t.pieces.empty());
  const RobotProfile& robot = request.profile;
  EXPECT_EQ(t.dimension, robot.active_height ? 4 : 3);
  // Safe by a check written apart from the verifier, at its own dense samples: the stats
  // below are the verifier's own figures and could not catch a verifier that misses a fault.
  std::vector<Prism> zones = map.keep_out();
  zones.insert(zones.end(), request.keep_out.begin(), request.keep_out.end());
  const bench::IndependentCheckConfig check =
      bench::CheckConfigFor(request.options.verifier, std::move(zones));
  const bench::IndependentCheckCounts broken = bench::CheckTrajectory(map.model(), robot, t, check);
  EXPECT_FALSE(broken.Any()) << "independent check: " << broken.Describe();
  // Boundary states: the snapped positions, the requested velocity and acceleration.
  EXPECT_LT((t.Position(0).head<3>() - plan.start.position_m).norm(), 1e-9);
  EXPECT_LT((t.Position(t.TotalDuration()).head<3>() - plan.goal.position_m).norm(), 1e-9);
  EXPECT_LT((t.Velocity(0).head<3>() - request.start.velocity_mps).norm(), 1e-9);
  EXPECT_LT((t.Velocity(t.TotalDuration()).head<3>() - request.goal.velocity_mps).norm(), 1e-9);
  EXPECT_LT((t.Acceleration(0).head<3>() - request.start.acceleration_mps2).norm(), 1e-9);
  EXPECT_LT((t.Acceleration(t.TotalDuration()).head<3>() - request.goal.acceleration_mps2).norm(),
            1e-9);
  // The verified limits, as reported.
  const PlanStats& s = plan.stats;
  EXPECT_LE(s.max_speed_horizontal_mps, 1.01 * robot.max_speed_horizontal_mps);
  EXPECT_LE(s.max_speed_vertical_mps, 1.01 * robot.max_speed_vertical_mps);
  EXPECT_LE(s.max_accel_horizontal_mps2, 1.01 * robot.max_accel_horizontal_mps2);
  EXPECT_LE(s.max_accel_vertical_mps2, 1.01 * robot.max_accel_vertical_mps2);
  EXPECT_LE(s.max_ground_offset_m, request.options.verifier.ground_tolerance_m);
  EXPECT_GE(s.min_headroom_m,
            robot.headroom_m - BodyHeightTolerance(robot, request.options.verifier));
  EXPECT_GT(s.verified_samples, s.length_m / 0.021);
  // Smoothing cuts the grid path's corners; a retried optimisation (stiffer penalties) can
  // swerve a little (7% measured on the two-level ramp), never much. A warm start has no path.
  if (!s.warm_started) {
    EXPECT_LE(s.length_m, 1.1 * plan.path.length_m + 0.5);
    EXPECT_GT(s.length_m, 0.5 * plan.path.length_m);
  }
  EXPECT_NEAR(s.duration_s, t.TotalDuration(), 1e-9);
  // The bound named as limiting is the one whose peak comes closest.
  const double fraction = std::max({s.max_speed_horizontal_mps / robot.max_speed_horizontal_mps,
                                    s.max_speed_vertical_mps / robot.max_speed_vertical_mps,
                                    s.max_accel_horizontal_mps2 / robot.max_accel_horizontal_mps2,
                                    s.max_accel_vertical_mps2 / robot.max_accel_vertical_mps2});
  EXPECT_DOUBLE_EQ(s.limiting_bound_fraction, fraction);
  EXPECT_THAT(s.limiting_bound, testing::AnyOf("horizontal_speed", "vertical_speed",
                                               "horizontal_acceleration", "vertical_acceleration"));
  EXPECT_GT(s.timings.total_s, 0);
}

class TwoLevelPlan : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { map_ = new PlanningMap(Assess(GenerateTwoLevelRamp(5), 0.1)); }
  static void TearDownTestSuite() { delete map_; }
  static PlanningMap* map_;
  const TwoLevelRampLayout layout_ = GetTwoLevelRampLayout();
};
PlanningMap* TwoLevelPlan::map_ = nullptr;

TEST_F(TwoLevelPlan, FloorToDeckClimbsTheRampOnTheGround) {
  const PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  auto plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ExpectSound(*map_, *plan, request);
  EXPECT_EQ(plan->start.level, 0);
  EXPECT_EQ(plan->goal.level, 1);
  // Every sample is at the reference height above the ground, so the way up is the ramp.
  const Trajectory& t = plan->trajectory;
  bool crossed_ramp = false;
  for (double time = 0; time <= t.TotalDuration(); time += 0.1) {
    const Eigen::Vector3d p = t.Position(time).head<3>();
    const double ground = test_util::GroundHeightBelow(map_->model(), p).value_or(-100);
    EXPECT_NEAR(p.z() - ground, 0.3, 0.15) << p.transpose();
    if (p.z() > layout_.floor_z_m + 1.0 && p.z() < layout_.deck_z_m - 0.5) {
      EXPECT_GT(p.x(), layout_.ramp_x_min_m - 0.3) << p.transpose();
      EXPECT_LT(p.x(), layout_.ramp_x_max_m + 0.3) << p.transpose();
      EXPECT_GT(p.y(), layout_.ramp_y_min_m - 0.3) << p.transpose();
      EXPECT_LT(p.y(), layout_.ramp_y_max_m + 0.3) << p.transpose();
      crossed_ramp = true;
    }
  }
  EXPECT_TRUE(crossed_ramp);
}

// The first plan of a profile on a map builds its surface graph, the next looks it up: the
// stage is timed on its own, so that the stages of a first plan add up to its total.
TEST_F(TwoLevelPlan, TheGraphBuildIsAStageOfItsOwn) {
  const PlanningMap fresh(map_->model_ptr());
  const PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  auto first = Plan(fresh, request);
  auto second = Plan(fresh, request);
  ASSERT_TRUE(first.ok() && second.ok());
  const PlanTimings& built = first->stats.timings;
  const PlanTimings& looked_up = second->stats.timings;
  EXPECT_GT(built.graph_s, 10 * looked_up.graph_s);
  EXPECT_LT(built.snap_s, built.graph_s);
  for (const PlanTimings& t : {built, looked_up}) {
    const double stages = t.graph_s + t.snap_s + t.search_s + t.optimize_s + t.verify_s;
    EXPECT_LE(stages, t.total_s);
    EXPECT_GT(stages, 0.9 * t.total_s);
  }
}

TEST_F(TwoLevelPlan, BadRequestsGetNamedErrors) {
  PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.start.position_m.x() = std::nan("");
  auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(plan.error().message, HasSubstr("start.position_m"));
  EXPECT_EQ(plan.error().field, "start.position_m.x");

  request = Request(layout_.start_example_m, {layout_.room_x_max_m + 10, 3, 0});
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalOffGround);
  EXPECT_THAT(plan.error().message, HasSubstr("the nearest is"));
  EXPECT_EQ(plan.error().field, "goal.position_m");

  request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.profile.footprint_radius_m = 0.5;  // The map was filtered for 0.3 m.
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kProfileMismatch);
  EXPECT_THAT(plan.error().message, HasSubstr("radius of at least 0.5"));
  EXPECT_EQ(plan.error().field, "profile.footprint_radius_m");

  request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.options.optimizer.weights.time = -1;
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(plan.error().message, HasSubstr("weights.time"));
  EXPECT_EQ(plan.error().field, "options.optimizer.weights.time");
}

// A plan has one time budget, options.time_budget_s (with the caller's deadline): the search
// has none of its own. When it runs out, the message names it, and raising it helps.
TEST_F(TwoLevelPlan, ARunOutBudgetNamesTheOptionThatRaisesIt) {
  PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.options.time_budget_s = 1e-9;  // Gone before the first poll.
  // A map's first plan for a profile builds the profile's graph, and the budget covers it.
  const PlanningMap fresh(map_->model_ptr());
  auto plan = Plan(fresh, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kDeadlineExceeded);
  EXPECT_THAT(plan.error().message, HasSubstr("ran out during building the surface graph"));
  EXPECT_EQ(fresh.GraphCount(), 0u);  // Not kept: the next plan builds it.
  // Once the graph is built, the first poll is the search's.
  ASSERT_TRUE(map_->Graph(request.profile.Traversability()).ok());
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kDeadlineExceeded);
  EXPECT_THAT(plan.error().message, HasSubstr("ran out during the path search"));
  EXPECT_THAT(plan.error().message, HasSubstr("allow more time (options.time_budget_s"));
  request.options.time_budget_s = 60;
  plan = Plan(*map_, request);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
}

// A should_stop that counts its polls and fires from the `fire_at`-th on (0: never).
struct CountingStop {
  int fire_at = 0;
  int polls = 0;
  bool operator()() { return ++polls >= fire_at && fire_at > 0; }
};

TEST_F(TwoLevelPlan, CancellationStopsAtTheFirstPollThatAsksInEveryStage) {
  const PlanRequest request = Request({2, 5.2, 0.3}, {13, 8, 0.3});  // Optimised at once.
  ASSERT_TRUE(map_->Graph(request.profile.Traversability()).ok());   // Built: no build polls.
  // How often a whole plan polls, then a cancellation at the first poll and at the last: the
  // plan ends at that very poll (no further poll), naming the stage.
  CountingStop never;
  ASSERT_TRUE(Plan(*map_, request, std::ref(never)).ok());
  ASSERT_GT(never.polls, 2);
  for (const int fire_at : {1, never.polls}) {
    CountingStop stop{fire_at};
    const auto plan = Plan(*map_, request, std::ref(stop));
    ASSERT_FALSE(plan.ok()) << "fire_at " << fire_at;
    EXPECT_EQ(plan.error().code, ErrorCode::kCancelled);
    EXPECT_THAT(plan.error().message, HasSubstr(fire_at == 1 ? "during the path search"
                                                             : "during trajectory optimisation"));
    EXPECT_EQ(stop.polls, fire_at);
  }
}

TEST_F(TwoLevelPlan, ABudgetSpentBeforeTheFirstPollEndsThePlanAtThatPoll) {
  PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  // Below the clock's resolution: the deadline is the start time itself, so it has passed at
  // the first poll whatever the machine's speed.
  request.options.time_budget_s = 1e-12;
  CountingStop polls;
  const auto plan = Plan(*map_, request, std::ref(polls));
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kDeadlineExceeded);
  EXPECT_THAT(plan.error().message, HasSubstr("time budget of 0.000 s"));
  EXPECT_EQ(polls.polls, 1);
}

// A plan whose optimiser ignores the speed bounds (no feasibility penalty) and values time far
// above smoothness races through: every attempt fails verification, and Plan reports the
// violation.
// An optimiser that ignores the bounds (no feasibility penalty, time at a premium) makes
// trajectories far too fast to stretch within kMaxTimeStretch: every attempt fails, and the
// plan falls back to the slow trajectory along the path, marked as such.
TEST_F(TwoLevelPlan, WhenEveryAttemptFailsTheSlowFallbackIsReturnedAndMarked) {
  PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.options.optimizer.weights.feasibility = 0;
  request.options.optimizer.weights.time = 1e4;
  const auto plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_TRUE(plan->stats.fallback);
  EXPECT_THAT(plan->stats.fallback_reason, HasSubstr("trajectory verification failed"));
  EXPECT_EQ(plan->stats.optimizer_attempts, request.options.max_attempts);
  ExpectSound(*map_, *plan, request);
  // An ordinary plan is not marked (on the floor: on this map's ramp, rough at 0.1 m, the
  // floor-to-deck plan itself ends in the fallback).
  const auto ordinary = Plan(*map_, Request({2, 5.2, 0.3}, {13, 8, 0.3}));
  ASSERT_TRUE(ordinary.ok()) << ordinary.error().message;
  EXPECT_FALSE(ordinary->stats.fallback);
}

// A verifier no trajectory can satisfy (the reference point within a micrometre of the
// ground's height): every attempt and the fallback fail, and the error says so.
TEST_F(TwoLevelPlan, ATrajectoryThatNeverPassesVerificationIsOptimizationFailed) {
  PlanRequest request = Request(layout_.start_example_m, layout_.goal_example_m);
  request.options.verifier.ground_tolerance_m = 1e-6;
  const auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kOptimizationFailed);
  EXPECT_THAT(plan.error().message, HasSubstr("trajectory verification failed"));
  EXPECT_THAT(plan.error().message,
              HasSubstr("(after " + std::to_string(request.options.max_attempts) +
                        " attempts and the slow fallback)"));
}

// Replanning on the way: from a state on a trajectory the robot follows, with that trajectory
// as the warm start, the optimiser starts from its remainder and needs fewer iterations than
// a plan from scratch; the plan still ends at the goal and passes verification.
TEST_F(TwoLevelPlan, AWarmStartReplansInFewerIterationsThanACold) {
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> queries[] = {
      {{2, 5.2, 0.3}, {13, 8, 0.3}},  // Floor, under the deck.
      {{6, 8, 3.3}, {14, 11, 3.3}},   // Across the deck.
      {{1, 5, 0.3}, {16, 11, 0.3}},   // Floor, between the pillars.
      {{8, 8, 3.3}, {18, 3, 3.3}}};   // Deck to the tongue.
  int warm_iterations = 0, cold_iterations = 0;
  for (const auto& [from, to] : queries) {
    const auto first = Plan(*map_, Request(from, to));
    ASSERT_TRUE(first.ok()) << first.error().message;
    const Trajectory& followed = first->trajectory;
    const double now = 0.3 * followed.TotalDuration();
    PlanRequest replan = Request(from, to);
    replan.start.position_m = followed.Position(now).head<3>();
    replan.start.velocity_mps = followed.Velocity(now).head<3>();
    replan.start.acceleration_mps2 = followed.Acceleration(now).head<3>();
    replan.goal.position_m = first->goal.position_m;
    const auto cold = Plan(*map_, replan);
    replan.warm_start = WarmStart{followed, now};
    const auto warm = Plan(*map_, replan);
    ASSERT_TRUE(cold.ok()) << cold.error().message;
    ASSERT_TRUE(warm.ok()) << warm.error().message;
    EXPECT_TRUE(warm->stats.warm_started);
    EXPECT_FALSE(cold->stats.warm_started);
    EXPECT_EQ(warm->stats.search_expansions, 0);
    ExpectSound(*map_, *warm, replan);
    warm_iterations += warm->stats.optimizer_iterations;
    cold_iterations += cold->stats.optimizer_iterations;
  }
  // Over the set (one query alone may take as many: the remainder is optimal for the old
  // start, at rest, not for the moving one).
  EXPECT_LT(warm_iterations, 0.6 * cold_iterations);
}

TEST_F(TwoLevelPlan, AWarmStartThatDoesNotFitFallsBackToASearch) {
  const auto first = Plan(*map_, Request(layout_.start_example_m, layout_.goal_example_m));
  ASSERT_TRUE(first.ok()) << first.error().message;
  // The goal moved 3 m: the remainder of the old trajectory ends elsewhere.
  PlanRequest replan = Request(layout_.start_example_m, layout_.goal_example_m);
  replan.goal.position_m.x() -= 3;
  replan.warm_start = WarmStart{first->trajectory, 0};
  const auto plan = Plan(*map_, replan);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_FALSE(plan->stats.warm_started);
  EXPECT_GT(plan->stats.search_expansions, 0);
  // A trajectory of the wrong dimension is a bad request, named by its field.
  replan.warm_start->trajectory.dimension = 4;
  const auto bad = Plan(*map_, replan);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "warm_start.trajectory.dimension");
}

// Keep-out zones on the two-level hall's floor, under the deck: x in [6, 13] along y = 8 is
// open floor (the pillars stand at y = 9.25), so the straight way crosses a zone around
// x = 9.5; the way round is south of it, the pillar closes the north.
class KeepOutPlan : public TwoLevelPlan {
 protected:
  // Zone of the floor's storey: from below the floor to below the deck's ground (3 m).
  static Prism FloorZone(double x_min, double x_max, double y_min, double y_max) {
    return BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(x_min, y_min, -0.5),
                                        Eigen::Vector3d(x_max, y_max, 2.5)));
  }
  const Eigen::Vector3d west_{6, 8, 0.3}, east_{13, 8, 0.3};
  const Prism zone_ = FloorZone(9, 10, 7, 9);
};

// Reference points every 2 cm or closer along the trajectory.
std::vector<Eigen::Vector3d> DenseSamples(const Trajectory& t) {
  std::vector<Eigen::Vector3d> samples;
  const double dt = 0.01;  // At most 1 m/s: 1 cm apart.
  for (double time = 0; time < t.TotalDuration(); time += dt) {
    samples.emplace_back(t.Position(time).head<3>());
  }
  samples.emplace_back(t.Position(t.TotalDuration()).head<3>());
  return samples;
}

TEST_F(KeepOutPlan, ThePlanGoesAroundAZoneItWouldCrossAndStillVerifies) {
  PlanRequest request = Request(west_, east_);
  const auto straight = Plan(*map_, request);
  ASSERT_TRUE(straight.ok()) << straight.error().message;
  bool crossed = false;
  for (const Eigen::Vector3d& p : DenseSamples(straight->trajectory)) {
    crossed = crossed || zone_.ContainsXY(p.head<2>());
  }
  ASSERT_TRUE(crossed) << "without the zone the plan must pass through it, or the test is moot";
  // Verified against the zone, that plan fails naming it.
  const auto graph = map_->Graph(request.profile.Traversability()).value();
  const std::vector<KeepOutZone> zones = {KeepOutZone(zone_, "keep-out zone keep_out[0]")};
  VerificationReport report;
  const Status refused = VerifyTrajectory(*graph, request.profile, straight->trajectory,
                                          request.options.verifier, &report, zones);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kOptimizationFailed);
  EXPECT_THAT(refused.error().message, HasSubstr("inside keep-out zone keep_out[0]"));

  request.keep_out = {zone_};
  const auto around = Plan(*map_, request);
  ASSERT_TRUE(around.ok()) << around.error().message;
  ExpectSound(*map_, *around, request);
  for (const Eigen::Vector3d& p : DenseSamples(around->trajectory)) {
    EXPECT_GE(zone_.SignedDistanceXY(p.head<2>()), request.profile.footprint_radius_m)
        << p.transpose();
  }
  for (const Eigen::Vector3d& p : around->path.points_m) {
    EXPECT_FALSE(ViolatesKeepOut(zone_, request.profile, p)) << "A* node " << p.transpose();
  }
  EXPECT_TRUE(VerifyTrajectory(*graph, request.profile, around->trajectory,
                               request.options.verifier, &report, zones)
                  .ok());
}

TEST_F(KeepOutPlan, AMapZoneIsHonouredLikeARequestZone) {
  const PlanningMap map(map_->model_ptr(), {zone_});
  ASSERT_EQ(map.keep_out().size(), 1u);
  const PlanRequest request = Request(west_, east_);
  const auto around = Plan(map, request);
  ASSERT_TRUE(around.ok()) << around.error().message;
  ExpectSound(map, *around, request);
  for (const Eigen::Vector3d& p : DenseSamples(around->trajectory)) {
    EXPECT_GE(zone_.SignedDistanceXY(p.head<2>()), request.profile.footprint_radius_m)
        << p.transpose();
  }
  const auto refused = Plan(map, Request(west_, {9.5, 8, 0.3}));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kGoalInKeepOut);
  EXPECT_THAT(refused.error().message, HasSubstr("the map's keep-out zone 0"));
}

TEST_F(KeepOutPlan, AStartOrGoalInsideAZoneIsRefusedNamingIt) {
  PlanRequest request = Request(west_, {9.5, 8, 0.3});
  request.keep_out = {FloorZone(1, 2, 1, 2), zone_};
  auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalInKeepOut);
  EXPECT_EQ(plan.error().field, "goal.position_m");
  EXPECT_THAT(plan.error().message, HasSubstr("goal (9.50, 8.00, 0.30) m"));
  EXPECT_THAT(plan.error().message, HasSubstr("keep_out[1]"));
  EXPECT_THAT(plan.error().message, HasSubstr("move the goal"));

  // Outside the polygon, but the footprint reaches into it.
  request = Request({9.5, 6.8, 0.3}, east_);
  request.keep_out = {zone_};
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kStartInKeepOut);
  EXPECT_EQ(plan.error().field, "start.position_m");
  EXPECT_THAT(plan.error().message, HasSubstr("keep_out[0]"));
  EXPECT_THAT(plan.error().message, HasSubstr("reaches 0.10 m into"));
}

TEST_F(KeepOutPlan, AZoneOnTheOtherStoreyDoesNotBlock) {
  // The same floor zone under a plan on the deck above it: straight through its x, y.
  PlanRequest request = Request({6, 8, 3.3}, {13, 8, 3.3});
  request.keep_out = {zone_};
  auto plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  bool over_zone = false;
  for (const Eigen::Vector3d& p : DenseSamples(plan->trajectory)) {
    over_zone = over_zone || zone_.ContainsXY(p.head<2>());
  }
  EXPECT_TRUE(over_zone);
  // And a goal in the deck's x, y above a floor zone is no goal inside it.
  request = Request({6, 8, 3.3}, {9.5, 8, 3.3});
  request.keep_out = {zone_};
  EXPECT_TRUE(Plan(*map_, request).ok());
  // The deck's own zone does block there.
  request.keep_out = {
      BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(9, 7, 2.9), Eigen::Vector3d(10, 9, 5.0)))};
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalInKeepOut);
}

TEST_F(KeepOutPlan, ZonesThatCloseEveryWayMakeTheGoalUnreachableNamingThem) {
  // A wall across the hall's floor storey and the ramp: the east floor is cut off. The message
  // names the zones the search met, not one on the deck it never reached.
  PlanRequest request = Request(west_, east_);
  const Prism on_the_deck =
      BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(2, 8, 2.9), Eigen::Vector3d(3, 9, 5.0)));
  request.keep_out = {on_the_deck, FloorZone(11, 11.5, -1, 13)};
  const auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_THAT(plan.error().message, HasSubstr("keep-out zone keep_out[1]"));
  EXPECT_THAT(plan.error().message, Not(HasSubstr("keep_out[0]")));
  EXPECT_EQ(plan.error().details.at("zones_in_the_way"), "keep-out zone keep_out[1]");
}

TEST_F(KeepOutPlan, MalformedZonesAreBlamedByTheirPath) {
  PlanRequest request = Request(west_, east_);
  request.keep_out = {zone_, zone_};
  request.keep_out[1].polygon_m[2].x() = std::nan("");
  auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(plan.error().field, "keep_out[1].polygon_m[2].x");

  request.keep_out = {zone_};
  request.keep_out[0].z_max_m = request.keep_out[0].z_min_m;
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().field, "keep_out[0].z_max_m");
  EXPECT_THAT(plan.error().message, HasSubstr("blocks nothing"));

  request.keep_out.assign(kMaxRequestKeepOutZones + 1, zone_);
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().field, "keep_out");
}

// test_util::TableRoom: a wall whose only opening is under a table 0.45 m high.
TEST(TableRoom, TheBipedCrouchesUnderTheTableWhereTheDifferentialRobotCannotPass) {
  const PlanningMap map(Assess(test_util::TableRoom(), 0.1));
  const Eigen::Vector3d start(1.5, 2.0, 0.3), goal(6.5, 2.0, 0.3);

  const PlanRequest wheeled = Request(start, goal, "differential");
  auto blocked = Plan(map, wheeled);
  ASSERT_FALSE(blocked.ok());
  EXPECT_EQ(blocked.error().code, ErrorCode::kGoalUnreachable);
  {
    // The two components, by the labels of the graph the plan searched, and their sizes.
    const auto graph = map.Graph(wheeled.profile.Traversability()).value();
    const auto& details = blocked.error().details;
    const auto component_of = [&](const Eigen::Vector3d& p) {
      return graph->component(SnapToSurface(*graph, p, 1.0, ErrorCode::kStartOffGround)->node);
    };
    const int start_component = component_of(start), goal_component = component_of(goal);
    EXPECT_NE(start_component, goal_component);
    EXPECT_EQ(details.at("start_component"), std::to_string(start_component));
    EXPECT_EQ(details.at("goal_component"), std::to_string(goal_component));
    int start_nodes = 0;
    for (int m = 0; m < graph->node_count(); ++m)
      start_nodes += graph->component(m) == start_component;
    EXPECT_EQ(details.at("start_component_nodes"), std::to_string(start_nodes));
    EXPECT_GT(std::stoi(details.at("goal_component_nodes")), 0);
  }

  const PlanRequest biped = Request(start, goal, "biped");
  auto plan = Plan(map, biped);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ExpectSound(map, *plan, biped);
  const Trajectory& t = plan->trajectory;
  ASSERT_EQ(t.dimension, 4);
  double under_table = 1e9, in_the_open = 0;
  for (double time = 0; time <= t.TotalDuration(); time += 0.05) {
    const Eigen::VectorXd q = t.Position(time);
    if (std::abs(q.x() - 4.0) < 0.3) under_table = std::min(under_table, q(3));
    if (std::abs(q.x() - 4.0) > 1.5) in_the_open = std::max(in_the_open, q(3));
    EXPECT_GE(q(3), biped.profile.body_height_min_m - 0.01);
    EXPECT_LE(q(3), biped.profile.body_height_max_m + 0.01);
  }
  // The body fits under the table with the profile's headroom above it, up to the verifier's
  // stated tolerance.
  const double tolerance = BodyHeightTolerance(biped.profile, biped.options.verifier);
  EXPECT_LE(under_table, 0.45 - biped.profile.headroom_m + tolerance);
  EXPECT_GT(in_the_open, 0.6) << "away from the table it stands near its preferred height";
  EXPECT_LE(plan->stats.min_body_height_m, 0.45 - biped.profile.headroom_m + tolerance);
  EXPECT_GE(plan->stats.min_headroom_m, biped.profile.headroom_m - tolerance);
}

// The farthest the trajectory strays in x, y from the straight line between its ends [m].
double LargestSidewaysOffset(const Trajectory& t) {
  const Eigen::Vector2d a = t.Position(0).head<2>();
  const Eigen::Vector2d along = (t.Position(t.TotalDuration()).head<2>() - a).normalized();
  double largest = 0;
  for (double time = 0; time <= t.TotalDuration(); time += 0.01) {
    const Eigen::Vector2d d = t.Position(time).head<2>() - a;
    largest = std::max(largest, (d - d.dot(along) * along).norm());
  }
  return largest;
}

// PlanOptions.rim_weight (SearchConfig::rim_weight): by default the search keeps a path between
// two points beside a wall off the rim of the ground in between; with the rim weight at 0 it
// runs straight along the wall, and verifies just the same.
TEST(WallSide, WithoutTheRimWeightAPathBesideAWallRunsStraight) {
  test_util::CloudBuilder room(0.05);
  room.Plate(0, 10, 0, 4, 0).Block(0, 10, 0, 0.1, 0.05, 1.5);  // A floor, a wall along y = 0.
  const PlanningMap map(Assess(room.cloud(), 0.1));
  PlanRequest request = Request({1, 0.5, 0.3}, {9, 0.5, 0.3});
  const Expected<PlanResult> kept_off = Plan(map, request);
  ASSERT_TRUE(kept_off) << kept_off.error().message;
  ExpectSound(map, *kept_off, request);
  EXPECT_GT(LargestSidewaysOffset(kept_off->trajectory), 0.3);  // 0.42 m measured.
  request.options.search.rim_weight = 0;
  const Expected<PlanResult> straight = Plan(map, request);
  ASSERT_TRUE(straight) << straight.error().message;
  ExpectSound(map, *straight, request);
  EXPECT_LT(LargestSidewaysOffset(straight->trajectory), 0.1);  // 0.05 m measured.
}

// indoor_tables (seed 1), between two points 0.3 and 0.5 m from its south wall. While a wall's
// inside counted as a void, S' was 2-5 there and the trajectory swerved into the room and back
// (κ 0.59); a wall adds nothing to S' now (safety_field.hpp), and it runs almost straight.
TEST(WallSide, APathAlongAWallRunsStraight) {
  const PlanningMap map(Assess(GenerateIndoorTables(1), 0.2));
  const PlanRequest request = Request({8.695, 0.295, 0.205}, {4.495, 0.495, 0.205}, "biped");
  const Expected<PlanResult> plan = Plan(map, request);
  ASSERT_TRUE(plan) << plan.error().message;
  ExpectSound(map, *plan, request);
  EXPECT_LT(plan->stats.mean_curvature_per_m, 0.15);  // 0.073 measured.
}

TEST(StairsRampRoomPlan, TheTrajectoryTakesTheRampNotTheStairs) {
  const PlanningMap map(Assess(GenerateStairsRampRoom(3, 0.05), 0.1));
  const StairsRampLayout L = GetStairsRampLayout();
  const double stairs_x = 0.5 * (L.stairs_x_min_m + L.stairs_x_max_m);
  const PlanRequest request =
      Request({stairs_x, L.stairs_y_min_m - 1.0, 0.3},
              {stairs_x, 0.5 * (L.landing_y_min_m + L.room_y_max_m), L.landing_z_m + 0.3});
  auto plan = Plan(map, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ExpectSound(map, *plan, request);
  const Trajectory& t = plan->trajectory;
  for (double time = 0; time <= t.TotalDuration(); time += 0.05) {
    const Eigen::Vector3d p = t.Position(time).head<3>();
    const bool over_stairs = p.x() > L.stairs_x_min_m + 0.1 && p.x() < L.stairs_x_max_m - 0.1 &&
                             p.y() > L.stairs_y_min_m + 0.1 && p.y() < L.stairs_y_max_m - 0.1;
    EXPECT_FALSE(over_stairs) << p.transpose();
  }
}

// The shared maps: a test skips when ../shared/maps is absent, and fails when a map is there
// but does not load.
std::string SharedMapPath(const std::string& name) {
  return std::string(STRATA_SHARED_MAPS_DIR) + "/" + name;
}

std::shared_ptr<const TerrainModel> LoadShared(const std::string& path, double resolution_m) {
  auto cloud = LoadPointCloud(path, CloudLoadLimits{});
  EXPECT_TRUE(cloud.ok()) << path << ": " << cloud.error().message;
  if (!cloud) return nullptr;
  return Assess(cloud->points, resolution_m);
}

// The spiral at 0.2 m, assessed once for the tests that read it (about 9 s under the
// sanitisers); null when the map does not load.
std::shared_ptr<const TerrainModel> SpiralAt02() {
  static const std::shared_ptr<const TerrainModel> model =
      LoadShared(SharedMapPath("spiral0.3_2.pcd"), 0.2);
  return model;
}

TEST(SharedMaps, Scene20QueriesSucceedOnTheGround) {
  const std::string path = SharedMapPath("scene20.2.pcd");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared maps not found at " << path;
  const auto model = LoadShared(path, 0.2);
  ASSERT_NE(model, nullptr);
  const PlanningMap map(model);
  // From ../shared/maps/README.md: s2_flat_diag, s2_under_deck, s2_around_walls.
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> queries[] = {
      {{-6, -8, 1}, {16, 16, 1}}, {{0, -2, 1}, {13, -2, 1}}, {{-5, -8, 1}, {15, -8, 1}}};
  for (const auto& [start, goal] : queries) {
    const PlanRequest request = Request(start, goal);
    auto plan = Plan(map, request);
    ASSERT_TRUE(plan.ok()) << start.transpose() << ": " << plan.error().message;
    ExpectSound(map, *plan, request);
  }
  // s2_ground_to_deck and s2_deck_to_ground: up and down the corridor's stepped ramp (0.15 m
  // risers on a 0.15 m voxel lattice, within the profile's step) to the deck at z = 2.9 m.
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> deck_queries[] = {
      {{-4, 16, 1}, {6.5, -1.5, 3.5}}, {{6.5, -2, 3.5}, {16, 8, 1}}};
  for (const auto& [start, goal] : deck_queries) {
    const PlanRequest request = Request(start, goal);
    auto plan = Plan(map, request);
    ASSERT_TRUE(plan.ok()) << start.transpose() << ": " << plan.error().message;
    ExpectSound(map, *plan, request);
    const Eigen::Vector3d deck_end =
        start.z() > goal.z() ? plan->start.position_m : plan->goal.position_m;
    EXPECT_NEAR(deck_end.z(), 2.9 + request.profile.reference_height_m, 0.1);
  }
}

TEST(SharedMaps, SpiralGroundQueriesSucceedAndAnIsolatedGoalIsRefusedWithoutSearch) {
  const std::string path = SharedMapPath("spiral0.3_2.pcd");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared maps not found at " << path;
  const auto model = SpiralAt02();
  ASSERT_NE(model, nullptr);
  const PlanningMap map(model);
  // sp_ground_left, sp_ground_right, sp_ground_to_l1 (up the first turn of the west ramp),
  // sp_ground_to_top and sp_top_to_ground (all five turns of a spiral, over the top deck).
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> queries[] = {{{-38, -2, 1.5}, {-26, -24, 1.5}},
                                                                 {{-18, 0, 1.5}, {8, 2, 1.5}},
                                                                 {{-30, -2, 1.5}, {-45, -29, 5.5}},
                                                                 {{-30, -2, 1.5}, {-30, -28, 21.5}},
                                                                 {{-16, -23, 21.5}, {-18, 0, 1.5}}};
  for (const auto& [start, goal] : queries) {
    const PlanRequest request = Request(start, goal);
    auto plan = Plan(map, request);
    ASSERT_TRUE(plan.ok()) << start.transpose() << ": " << plan.error().message;
    ExpectSound(map, *plan, request);
    // On the level the goal's z points at (the top deck's ground is at 20.2 m).
    EXPECT_NEAR(plan->goal.position_m.z() - goal.z(), 0.3 - 1.3, 0.25) << goal.transpose();
    // Anyone re-verifying with the default config gets the planner's verdict (the voxel
    // ground tolerance lives in VerifyTrajectory, not in Plan).
    const auto graph = map.Graph(request.profile.Traversability()).value();
    VerificationReport report;
    EXPECT_TRUE(
        VerifyTrajectory(*graph, request.profile, plan->trajectory, VerifierConfig{}, &report)
            .ok());
  }

  // A goal on an island of traversable ground (a component the start's does not reach).
  const PlanRequest probe = Request({-30, -2, 1.5}, {-26, -24, 1.5});
  const auto graph = map.Graph(probe.profile.Traversability()).value();
  const SnapResult start =
      SnapToSurface(*graph, probe.start.position_m, 1.0, ErrorCode::kStartOffGround).value();
  int island = -1;
  for (int m = 0; m < graph->node_count() && island < 0; ++m) {
    if (graph->component(m) != graph->component(start.node)) island = m;
  }
  ASSERT_GE(island, 0);
  // The search would poll before its first expansion: no poll, no search.
  CountingStop polls;
  auto refused =
      Plan(map, Request(probe.start.position_m, graph->position(island)), std::ref(polls));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_THAT(refused.error().message, HasSubstr("different connected components"));
  EXPECT_EQ(polls.polls, 0);
  // The same verdict from the search itself, with its expansion count.
  SearchStats stats;
  stats.expansions = -1;
  const auto search = SearchPath(*graph, start.node, island, SearchConfig{}, {}, &stats);
  ASSERT_FALSE(search.ok());
  EXPECT_EQ(search.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_EQ(stats.expansions, 0);
}

// On the spiral at 0.2 m the floor of column (−50.8, −24.6) was split in two grounds, 3.6 and
// 4.0 m, with the smoothed ground halfway (3.8 m): a robot at rest there stands on either as
// its reference point is rounded, and that it stays on one could never be shown. Such a node
// is not snapped to: a robot parked there by a plan that ended there (fleet_benchmark, seed
// 2) could not plan again, every plan from it failing verification at t = 0.
TEST(SharedMaps, OnTheSpiralAnEndHalfwayBetweenTwoGroundsSnapsWhereTheRobotStandsOnOne) {
  const std::string path = SharedMapPath("spiral0.3_2.pcd");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared maps not found at " << path;
  const auto model = SpiralAt02();
  ASSERT_NE(model, nullptr);
  const PlanningMap map(model);
  const Eigen::Vector3d split(-50.8, -24.6, 4.1);
  const Eigen::Vector3d elsewhere(-30, -2, 1.5);
  const Eigen::Vector2i column = model->grid().CellOf(split).head<2>();
  const auto grounds = model->surfaces().Column(column.x(), column.y());
  ASSERT_GE(grounds.size(), 2u);
  EXPECT_NEAR(grounds[1].ground_z_m - grounds[0].ground_z_m, 0.4, 1e-4);
  for (const auto& [start, goal] : {std::pair{split, elsewhere}, std::pair{elsewhere, split}}) {
    const PlanRequest request = Request(start, goal);
    auto plan = Plan(map, request);
    ASSERT_TRUE(plan.ok()) << start.transpose() << ": " << plan.error().message;
    ExpectSound(map, *plan, request);
    const Eigen::Vector3d end = start == split ? plan->start.position_m : plan->goal.position_m;
    EXPECT_NE(Eigen::Vector2i(model->grid().CellOf(end).head<2>()), column) << end.transpose();
    EXPECT_LE((end - split).head<2>().norm(), 0.3) << end.transpose();
  }
}

// A pair of strata-bench's 2000 on the spiral at 0.3 m (seed 1, index 1221) whose slow
// fallback along the shortened path leaves the ground's tolerance where a line crosses a
// ramp's edge: the fallback along the searched path as found, column centre to column
// centre, passes. Its three optimised attempts used to fail at a one-column pinch of the top
// deck; since the end pieces are split they pass, so here they are made to fail (no
// feasibility penalty, time at a premium: every one too fast for the bounds).
TEST(SharedMaps, OnTheSpiralTheFallbackFollowsTheSearchedPathWhereTheShortenedOneFails) {
  const std::string path = SharedMapPath("spiral0.3_2.pcd");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared maps not found at " << path;
  const auto model = LoadShared(path, 0.3);
  ASSERT_NE(model, nullptr);
  const PlanningMap map(model);
  PlanRequest request = Request({-54.15, -16.85, 18.7}, {-10.05, -27.05, 13.1});
  request.options.time_budget_s = 60 * test_util::kTimeScale;  // Whatever the machine's load.
  request.options.optimizer.weights.feasibility = 0;
  request.options.optimizer.weights.time = 1e4;
  const auto plan = Plan(map, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_TRUE(plan->stats.fallback);
  // Verified, as anyone re-verifying with the default config finds (the voxel map's ground
  // tolerance is the verifier's, not ExpectSound's).
  const auto graph = map.Graph(request.profile.Traversability()).value();
  VerificationReport report;
  EXPECT_TRUE(
      VerifyTrajectory(*graph, request.profile, plan->trajectory, VerifierConfig{}, &report).ok());
  // The path it follows is the search's: every step to one of the 8 neighbouring columns.
  const std::vector<Eigen::Vector3d>& points = plan->path.points_m;
  ASSERT_GT(points.size(), 2u);
  for (std::size_t k = 1; k < points.size(); ++k) {
    EXPECT_LE((points[k] - points[k - 1]).head<2>().norm(), std::sqrt(2.0) * 0.3 + 1e-6) << k;
  }
}

}  // namespace
}  // namespace strata
