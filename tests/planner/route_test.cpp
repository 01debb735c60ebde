// Plan through via-points (PlanRequest::via) on the two-level hall: stops split the route into
// legs from rest to rest, flow-through vias are pinned waypoints the trajectory passes at speed,
// and a via off the ground, unreachable, or one too many is refused naming it.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/planner.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/time_scale.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

class TwoLevelRoute : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    map_ = new PlanningMap(TerrainModel::Assess(GenerateTwoLevelRamp(5), config).value());
  }
  static void TearDownTestSuite() { delete map_; }

  PlanRequest Request(const Eigen::Vector3d& start, const Eigen::Vector3d& goal,
                      std::vector<Via> via) const {
    PlanRequest request;
    request.start.position_m = start;
    request.goal.position_m = goal;
    request.via = std::move(via);
    request.profile = BuiltinProfile("differential").value();
    request.options.time_budget_s *= 2 * test_util::kTimeScale;  // Several legs.
    return request;
  }
  // The whole trajectory passes the verifier, as each leg did.
  void ExpectVerified(const PlanRequest& request, const PlanResult& plan) const {
    const auto graph = map_->Graph(request.profile.Traversability()).value();
    VerificationReport report;
    const Status verified =
        VerifyTrajectory(*graph, request.profile, plan.trajectory, VerifierConfig{}, &report);
    EXPECT_TRUE(verified.ok()) << verified.error().message;
    EXPECT_NEAR(plan.stats.duration_s, plan.trajectory.TotalDuration(), 1e-9);
    EXPECT_EQ(plan.stats.pieces, static_cast<int>(plan.trajectory.pieces.size()));
  }

  static PlanningMap* map_;
  const TwoLevelRampLayout layout_ = GetTwoLevelRampLayout();
};
PlanningMap* TwoLevelRoute::map_ = nullptr;

TEST_F(TwoLevelRoute, ALegCacheGivesTheLegsAStopMovedLeftAloneAsTheyWouldBePlannedAgain) {
  const double deck = layout_.deck_z_m + 0.3;
  const auto request = [&](const Eigen::Vector3d& last_stop) {
    return Request(layout_.start_example_m, {3, 10, deck},
                   {{{8, 5.2, 0.3}, true}, {layout_.goal_example_m, true}, {last_stop, true}});
  };
  LegCache legs;
  ASSERT_TRUE(Plan(*map_, request({12, 8, deck}), {}, &legs).ok());
  EXPECT_EQ(legs.hits(), 0);
  // The last stop moved: the first two legs are the same, the last two are new.
  const PlanRequest moved = request({11, 7, deck});
  const auto cached = Plan(*map_, moved, {}, &legs);
  ASSERT_TRUE(cached.ok()) << cached.error().message;
  EXPECT_EQ(legs.hits(), 2);
  const auto fresh = Plan(*map_, moved);
  ASSERT_TRUE(fresh.ok()) << fresh.error().message;
  ASSERT_EQ(cached->trajectory.pieces.size(), fresh->trajectory.pieces.size());
  for (std::size_t i = 0; i < fresh->trajectory.pieces.size(); ++i) {
    EXPECT_EQ(cached->trajectory.pieces[i].duration_s, fresh->trajectory.pieces[i].duration_s);
    EXPECT_EQ(cached->trajectory.pieces[i].coefficients, fresh->trajectory.pieces[i].coefficients);
  }
  EXPECT_EQ(cached->via_times_s, fresh->via_times_s);
  EXPECT_EQ(cached->stats.length_m, fresh->stats.length_m);
  // Another zone, even out of the way, is another problem: nothing is taken.
  PlanRequest zoned = moved;
  zoned.keep_out.push_back(Prism{{{-9, -9}, {-8, -9}, {-8, -8}}, -1, 1});
  ASSERT_TRUE(Plan(*map_, zoned, {}, &legs).ok());
  EXPECT_EQ(legs.hits(), 2);
  // A flow-through via moved: its leg is planned again, the leg before it is taken.
  const auto through = [&](const Eigen::Vector3d& via) {
    return Request(layout_.start_example_m, {3, 10, deck}, {{{8, 5.2, 0.3}, true}, {via, false}});
  };
  ASSERT_TRUE(Plan(*map_, through(layout_.goal_example_m), {}, &legs).ok());
  EXPECT_EQ(legs.hits(), 3);
  const Eigen::Vector3d beside = layout_.goal_example_m + Eigen::Vector3d(0, 0.5, 0);
  ASSERT_TRUE(Plan(*map_, through(beside), {}, &legs).ok());
  EXPECT_EQ(legs.hits(), 4);
}

TEST_F(TwoLevelRoute, ThreeStopsOnTwoLevelsAreReachedAtRestAtTheTimesReported) {
  const double deck = layout_.deck_z_m + 0.3;
  const PlanRequest request = Request(layout_.start_example_m, {3, 10, deck},
                                      {{{8, 5.2, 0.3}, true},           // The floor.
                                       {layout_.goal_example_m, true},  // The deck, up the ramp.
                                       {{12, 8, deck}, true}});         // The deck again.
  const auto plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ExpectVerified(request, *plan);
  ASSERT_EQ(plan->via.size(), 3u);
  EXPECT_EQ(plan->via[0].level, 0);
  EXPECT_EQ(plan->via[1].level, 1);
  EXPECT_EQ(plan->via[2].level, 1);
  ASSERT_EQ(plan->via_times_s.size(), 3u);
  const Trajectory& t = plan->trajectory;
  double previous = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    const double at = plan->via_times_s[i];
    EXPECT_GT(at, previous + 1) << i;
    EXPECT_LT(at, t.TotalDuration() - 1) << i;
    previous = at;
    EXPECT_LT((t.Position(at).head<3>() - plan->via[i].position_m).norm(), 0.01) << i;
    EXPECT_LT(t.Velocity(at).head<3>().norm(), 1e-6) << i;
    EXPECT_LT(t.Acceleration(at).head<3>().norm(), 1e-6) << i;
    // Moving on either side: the stop is where it rests, not a pause along the way.
    EXPECT_GT(t.Velocity(at - 0.5).head<3>().norm(), 0.05) << i;
    EXPECT_GT(t.Velocity(at + 0.5).head<3>().norm(), 0.05) << i;
  }
  EXPECT_LT((t.Position(t.TotalDuration()).head<3>() - plan->goal.position_m).norm(), 1e-9);
}

TEST_F(TwoLevelRoute, AFlowThroughViaIsPassedExactlyAtSpeed) {
  const PlanRequest request = Request({2, 5.2, 0.3}, {13, 8, 0.3}, {{{7, 5.8, 0.3}, false}});
  const auto plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ExpectVerified(request, *plan);
  ASSERT_EQ(plan->via_times_s.size(), 1u);
  const double at = plan->via_times_s[0];
  const Trajectory& t = plan->trajectory;
  EXPECT_GT(at, 0);
  EXPECT_LT(at, t.TotalDuration());
  EXPECT_LT((t.Position(at).head<3>() - plan->via[0].position_m).norm(), 1e-3);
  EXPECT_NEAR(plan->via[0].position_m.x(), 7, 1e-9);  // The requested x, y on the ground.
  EXPECT_NEAR(plan->via[0].position_m.y(), 5.8, 1e-9);
  EXPECT_GT(t.Velocity(at).head<2>().norm(), 0.2);
}

TEST_F(TwoLevelRoute, AViaOffTheGroundIsBlamedByItsIndex) {
  const PlanRequest request =
      Request(layout_.start_example_m, {13, 8, 0.3},
              {{{7, 5.8, 0.3}, false}, {{layout_.room_x_max_m + 10, 3, 0}, true}});
  const auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalOffGround);
  EXPECT_EQ(plan.error().field, "via[1].position_m");
  EXPECT_THAT(plan.error().message, StartsWith("via[1] ("));
  EXPECT_THAT(plan.error().message, HasSubstr("the nearest is"));
}

TEST_F(TwoLevelRoute, AViaOnALevelTheRobotCannotReachNamesItsIndex) {
  PlanRequest request = Request(layout_.start_example_m, {8, 5.2, 0.3},
                                {{{7, 5.8, 0.3}, false}, {layout_.goal_example_m, true}});
  request.profile.max_tilt_rad = layout_.ramp_slope_rad * 0.6;  // The ramp is too steep.
  const auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_EQ(plan.error().field, "via[1]");
  EXPECT_THAT(plan.error().message, StartsWith("via[1] ("));
  EXPECT_THAT(plan.error().message, HasSubstr("connected to via[0] ("));
  EXPECT_EQ(plan.error().details.count("goal_component"), 1u);  // As the search gives them.
  // The goal after a via: named as the goal, from that via.
  request.goal.position_m = layout_.goal_example_m;
  request.via = {{{7, 5.8, 0.3}, false}};
  const auto goal = Plan(*map_, request);
  ASSERT_FALSE(goal.ok());
  EXPECT_EQ(goal.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_THAT(goal.error().message, StartsWith("goal ("));
  EXPECT_THAT(goal.error().message, HasSubstr("connected to via[0] ("));
}

TEST_F(TwoLevelRoute, BadViaListsAreRefusedBeforePlanning) {
  PlanRequest request = Request(layout_.start_example_m, {13, 8, 0.3}, {});
  request.via.resize(kMaxVias + 1, Via{{7, 5.8, 0.3}, false});
  auto plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(plan.error().field, "via");
  EXPECT_THAT(plan.error().message, HasSubstr(std::to_string(kMaxVias)));

  request.via = {{{7, 5.8, 0.3}, false}, {{7, std::nan(""), 0.3}, true}};
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(plan.error().field, "via[1].position_m.y");

  // Two vias on one ground cell would make a leg of no length.
  request.via = {{{7, 5.8, 0.3}, false}, {{7.01, 5.8, 0.3}, true}};
  plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(plan.error().field, "via[1]");
}

}  // namespace
}  // namespace strata
