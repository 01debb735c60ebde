#include "strata/travel_costs.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/planner.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/hand_made_maps.hpp"
#include "test_util/two_level_scene.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

RobotProfile Differential() { return BuiltinProfile("differential").value(); }

// Points every `step` along a straight line from a to b, both included.
std::vector<Eigen::Vector3d> Line(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double step) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= n; ++i) points.emplace_back(a + (b - a) * (static_cast<double>(i) / n));
  return points;
}

// ---- The drive along one path --------------------------------------------------------------

TEST(EstimateTravelTime, AStraightFlatDriveIsATrapezoidAtTheMarginedBounds) {
  const RobotProfile profile = Differential();
  TravelCostConfig config;
  config.speed_fraction = 0.9;  // Unlike limit_margin: each bound must take its own.
  ASSERT_NE(config.speed_fraction, config.limit_margin);
  const double v = config.speed_fraction * profile.max_speed_horizontal_mps;
  const double a = config.limit_margin * profile.max_accel_horizontal_mps2;
  const TravelTimeEstimate long_drive =
      EstimateTravelTime(Line({0, 0, 0.3}, {30, 0, 0.3}, 0.2), profile, config);
  EXPECT_NEAR(long_drive.length_m, 30.0, 1e-6);
  // Up to speed v and down again, each v / a long, cruising between.
  EXPECT_NEAR(long_drive.time_s, 30.0 / v + v / a, 1e-6);
  // Too short to reach v: a triangle, peak sqrt(a·L).
  const TravelTimeEstimate short_drive =
      EstimateTravelTime(Line({0, 0, 0.3}, {0.5, 0, 0.3}, 0.05), profile, config);
  EXPECT_NEAR(short_drive.time_s, 2 * std::sqrt(0.5 / a), 1e-6);
}

TEST(EstimateTravelTime, FewerThanTwoDistinctPointsTakeNoTime) {
  const std::vector<Eigen::Vector3d> same = {{1, 2, 3}, {1, 2, 3}};
  const TravelTimeEstimate none = EstimateTravelTime(same, Differential(), TravelCostConfig{});
  EXPECT_EQ(none.time_s, 0);
  EXPECT_EQ(none.length_m, 0);
}

TEST(EstimateTravelTime, TheVerticalBoundSlowsASteepSlopeOnly) {
  RobotProfile profile = Differential();
  const TravelCostConfig config;
  // A 20 m ramp rising 4 m (11.3°): at 1 m/s it would climb 0.2 m/s, under the 0.5 m/s bound.
  const auto ramp = Line({0, 0, 0.3}, {20, 0, 4.3}, 0.2);
  const double relaxed = EstimateTravelTime(ramp, profile, config).time_s;
  const double length = std::hypot(20.0, 4.0);
  const double v = config.speed_fraction * profile.max_speed_horizontal_mps;
  const double horizontal_share = 20.0 / length;
  const double a = config.limit_margin * profile.max_accel_horizontal_mps2 / horizontal_share;
  EXPECT_NEAR(relaxed, length / (v / horizontal_share) + (v / horizontal_share) / a, 1e-3);
  // A vertical bound of 0.1 m/s limits the climb to 0.1 / sin(11.3°) = 0.51 m/s along it.
  profile.max_speed_vertical_mps = 0.1;
  const double bound = EstimateTravelTime(ramp, profile, config).time_s;
  const double along = config.speed_fraction * 0.1 * length / 4.0;
  EXPECT_GT(bound, length / along);
  EXPECT_LT(bound, length / along + 2.0);
  // The same bound leaves flat ground alone.
  const auto flat = Line({0, 0, 0.3}, {20, 0, 0.3}, 0.2);
  EXPECT_DOUBLE_EQ(EstimateTravelTime(flat, profile, config).time_s,
                   EstimateTravelTime(flat, Differential(), config).time_s);
}

TEST(EstimateTravelTime, ACornerSlowsARobotFastEnoughToFeelIt) {
  // At 3 m/s and 1 m/s² a robot needs a radius of 9 m to turn at full speed; the corner,
  // rounded by the smoothing to about its window, makes it brake. At 1 m/s it does not.
  RobotProfile fast = Differential();
  fast.max_speed_horizontal_mps = 3;
  const TravelCostConfig config;
  std::vector<Eigen::Vector3d> corner = Line({0, 0, 0.3}, {20, 0, 0.3}, 0.2);
  const auto leg = Line({20, 0.2, 0.3}, {20, 20, 0.3}, 0.2);
  corner.insert(corner.end(), leg.begin(), leg.end());
  const TravelTimeEstimate turning = EstimateTravelTime(corner, fast, config);
  const auto straight = Line({0, 0, 0.3}, {turning.length_m, 0, 0.3}, 0.2);
  EXPECT_GT(turning.time_s, EstimateTravelTime(straight, fast, config).time_s + 1.0);
  EXPECT_NEAR(EstimateTravelTime(corner, Differential(), config).time_s,
              EstimateTravelTime(straight, Differential(), config).time_s, 0.2);
}

TEST(EstimateTravelTime, SmoothingTakesTheGridsZigzagOutOfTheLength) {
  // A staircase of axis and diagonal steps 0.2 m long along a line at 26.6° (two steps east,
  // one north-east): 8% longer than the line it follows.
  std::vector<Eigen::Vector3d> stairs = {{0, 0, 0.3}};
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d step =
        i % 2 == 0 ? Eigen::Vector3d(0.2, 0, 0) : Eigen::Vector3d(0.2, 0.2, 0);
    const Eigen::Vector3d next = stairs.back() + step;
    stairs.push_back(next);
  }
  const double line = (stairs.back() - stairs.front()).norm();
  TravelCostConfig config;
  const double raw =
      EstimateTravelTime(stairs, Differential(), TravelCostConfig{.smoothing_m = 0}).length_m;
  EXPECT_GT(raw, 1.05 * line);
  EXPECT_LT(EstimateTravelTime(stairs, Differential(), config).length_m, 1.015 * line);
}

TEST(EstimateTravelTime, DrivingBackTakesAsLongAsDrivingThere) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> wiggle(-0.3, 0.3);
  std::vector<Eigen::Vector3d> path;
  path.reserve(80);
  for (int i = 0; i < 80; ++i)
    path.emplace_back(0.25 * i, 2 * std::sin(0.1 * i) + wiggle(rng), 0.3 + 0.02 * i);
  std::vector<Eigen::Vector3d> reversed(path.rbegin(), path.rend());
  const TravelTimeEstimate there = EstimateTravelTime(path, Differential(), TravelCostConfig{});
  const TravelTimeEstimate back = EstimateTravelTime(reversed, Differential(), TravelCostConfig{});
  EXPECT_NEAR(there.time_s, back.time_s, 1e-9 * there.time_s);
  EXPECT_NEAR(there.length_m, back.length_m, 1e-9 * there.length_m);
}

// ---- Matrices --------------------------------------------------------------------------------

TEST(TravelCostConfig, ValidateBlamesTheField) {
  TravelCostConfig config;
  config.limit_margin = 1.5;
  Status s = config.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "costs.limit_margin");
  config = TravelCostConfig{};
  config.speed_fraction = 0;
  s = config.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "costs.speed_fraction");
  config = TravelCostConfig{};
  config.search.clearance_weight = -1;
  s = config.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "costs.search.clearance_weight");
  config = TravelCostConfig{};
  config.coarse_cell_m = std::nan("");
  EXPECT_EQ(config.Validate().error().field, "costs.coarse_cell_m");
  config = TravelCostConfig{};
  config.min_obstacle_distance_m = -0.1;
  EXPECT_EQ(config.Validate().error().field, "costs.min_obstacle_distance_m");
}

// A flat, walled 16 × 16 m floor at 0.2 m with a square pillar in the middle.
class FlatFloor : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    test_util::CloudBuilder builder(0.1);
    builder.Plate(0, 16, 0, 16, 0);
    builder.Block(7, 9, 7, 9, 0.1, 2.0);  // The pillar.
    AssessmentConfig config;
    config.grid.resolution_m = 0.2;
    model_ = new std::shared_ptr<const TerrainModel>(
        TerrainModel::Assess(builder.cloud(), config).value());
    graph_ =
        new SurfaceGraph(SurfaceGraph::Build(**model_, Differential().Traversability()).value());
  }
  static void TearDownTestSuite() {
    delete graph_;
    delete model_;
  }
  static const SurfaceGraph& graph() { return *graph_; }

  static std::shared_ptr<const TerrainModel>* model_;
  static SurfaceGraph* graph_;
};
std::shared_ptr<const TerrainModel>* FlatFloor::model_ = nullptr;
SurfaceGraph* FlatFloor::graph_ = nullptr;

TEST_F(FlatFloor, TheMatrixIsSymmetricForASymmetricRobotOnFlatGround) {
  const std::vector<Eigen::Vector3d> points = {{2, 2, 0.3},   {14, 3, 0.3},  {8, 13, 0.3},
                                               {3.3, 9, 0.3}, {12, 12, 0.3}, {6, 5.5, 0.3}};
  auto matrix =
      EstimateTravelCosts(graph(), Differential(), points, points, {}, 1.0, TravelCostConfig{});
  ASSERT_TRUE(matrix.ok()) << matrix.error().message;
  // Each search breaks ties between the many equally short grid paths by its own source, so
  // the two ways may take paths a cell or two apart: within 3% and 0.1 m (s), not exactly.
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(matrix->at(i, i).time_s, 0) << i;
    for (std::size_t j = 0; j < points.size(); ++j) {
      const TravelCost& there = matrix->at(i, j);
      const TravelCost& back = matrix->at(j, i);
      ASSERT_TRUE(there.reachable()) << i << " " << j;
      EXPECT_NEAR(there.search_cost, back.search_cost, 1e-4 * there.search_cost) << i << " " << j;
      EXPECT_NEAR(there.time_s, back.time_s, 0.03 * there.time_s + 0.1) << i << " " << j;
      EXPECT_NEAR(there.length_m, back.length_m, 0.03 * there.length_m + 0.1) << i << " " << j;
      // Never shorter than the straight line, and no longer than going round the pillar.
      const double line = (points[i] - points[j]).norm();
      EXPECT_GE(there.length_m, line - 0.05) << i << " " << j;
      EXPECT_LE(there.length_m, 1.2 * line + 0.2) << i << " " << j;
    }
  }
}

TEST_F(FlatFloor, EveryCellOfAStartOffTheGroundSaysSo) {
  const std::vector<Eigen::Vector3d> starts = {{2, 2, 0.3}, {30, 30, 0.3}, {8, 8, 0.3}};
  const std::vector<Eigen::Vector3d> goals = {{14, 14, 0.3}, {2, 14, 0.3}};
  Expected<TravelCostQuery> query =
      TravelCostQuery::Prepare(graph(), Differential(), starts, goals, {}, 1.0, TravelCostConfig{});
  ASSERT_TRUE(query.ok()) << query.error().message;
  ASSERT_FALSE(query->starts()[1].ok());
  EXPECT_EQ(query->starts()[1].error().code, ErrorCode::kStartOffGround);
  EXPECT_THAT(query->starts()[1].error().message, HasSubstr("the nearest is"));
  // Inside the pillar: no ground within a metre either.
  EXPECT_EQ(query->starts()[2].error().code, ErrorCode::kStartOffGround);
  auto matrix =
      EstimateTravelCosts(graph(), Differential(), starts, goals, {}, 1.0, TravelCostConfig{});
  ASSERT_TRUE(matrix.ok());
  for (int j = 0; j < 2; ++j) {
    EXPECT_TRUE(matrix->at(0, j).reachable());
    EXPECT_EQ(matrix->at(1, j).failure, ErrorCode::kStartOffGround);
    EXPECT_EQ(matrix->at(2, j).failure, ErrorCode::kStartOffGround);
  }
}

TEST_F(FlatFloor, SearchingFromTheGoalsGivesTheSameCells) {
  // One start, three goals: searched from the start; three starts, one goal: from the goal.
  const std::vector<Eigen::Vector3d> one = {{2, 2, 0.3}};
  const std::vector<Eigen::Vector3d> three = {{14, 3, 0.3}, {8, 13, 0.3}, {12, 12, 0.3}};
  auto row = EstimateTravelCosts(graph(), Differential(), one, three, {}, 1.0, TravelCostConfig{});
  auto column =
      EstimateTravelCosts(graph(), Differential(), three, one, {}, 1.0, TravelCostConfig{});
  ASSERT_TRUE(row.ok() && column.ok());
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(row->at(0, k).time_s, column->at(k, 0).time_s, 0.01 * row->at(0, k).time_s);
    EXPECT_NEAR(row->at(0, k).search_cost, column->at(k, 0).search_cost, 1e-4);
  }
}

TEST_F(FlatFloor, AKeepOutZoneAroundAGoalOrAcrossTheWayIsHonoured) {
  Prism zone;
  zone.polygon_m = {{10, 0}, {11, 0}, {11, 16}, {10, 16}};  // A wall of a zone across the floor.
  zone.z_min_m = -1;
  zone.z_max_m = 3;
  const std::vector<KeepOutZone> zones = {KeepOutZone(zone, "keep-out zone keep_out[0]")};
  const std::vector<Eigen::Vector3d> starts = {{2, 2, 0.3}};
  const std::vector<Eigen::Vector3d> goals = {{14, 14, 0.3}, {4, 14, 0.3}, {10.5, 5, 0.3}};
  Expected<TravelCostQuery> query =
      TravelCostQuery::Prepare(graph(), Differential(), starts, goals, zones, 1.0, {});
  ASSERT_TRUE(query.ok()) << query.error().message;
  EXPECT_EQ(query->goals()[2].error().code, ErrorCode::kGoalInKeepOut);
  EXPECT_THAT(query->goals()[2].error().message, HasSubstr("keep_out[0]"));
  auto matrix = EstimateTravelCosts(graph(), Differential(), starts, goals, zones, 1.0, {});
  ASSERT_TRUE(matrix.ok());
  EXPECT_EQ(matrix->at(0, 0).failure, ErrorCode::kGoalUnreachable);  // Behind the zone.
  EXPECT_TRUE(matrix->at(0, 1).reachable());
  EXPECT_EQ(matrix->at(0, 2).failure, ErrorCode::kGoalInKeepOut);
}

TEST_F(FlatFloor, CancellationAndLimitsFailTheCall) {
  const std::vector<Eigen::Vector3d> starts = {{2, 2, 0.3}};
  const std::vector<Eigen::Vector3d> goals = {{14, 14, 0.3}};
  auto cancelled =
      EstimateTravelCosts(graph(), Differential(), starts, goals, {}, 1.0, {}, [] { return true; });
  ASSERT_FALSE(cancelled.ok());
  EXPECT_EQ(cancelled.error().code, ErrorCode::kCancelled);
  // Stopped during the search itself: the ends and the graph are ready.
  Expected<TravelCostQuery> query =
      TravelCostQuery::Prepare(graph(), Differential(), starts, goals, {}, 1.0, {});
  ASSERT_TRUE(query.ok());
  ASSERT_EQ(query->search_count(), 1);
  TravelCostMatrix matrix = query->InitialMatrix();
  TravelCostWorkspace workspace;
  Status stopped = query->RunSearch(0, &workspace, &matrix, [] { return true; });
  ASSERT_FALSE(stopped.ok());
  EXPECT_EQ(stopped.error().code, ErrorCode::kCancelled);
  // The workspace is clean again: the same search now succeeds.
  ASSERT_TRUE(query->RunSearch(0, &workspace, &matrix).ok());
  EXPECT_GT(matrix.at(0, 0).time_s, 0);

  TravelCostConfig small;
  small.max_nodes = 100;
  auto too_big = EstimateTravelCosts(graph(), Differential(), starts, goals, {}, 1.0, small);
  ASSERT_FALSE(too_big.ok());
  EXPECT_EQ(too_big.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(too_big.error().message, HasSubstr("costs.max_nodes"));

  small = TravelCostConfig{};
  small.search.max_expansions = 10;
  auto budget = EstimateTravelCosts(graph(), Differential(), starts, goals, {}, 1.0, small);
  ASSERT_TRUE(budget.ok());
  EXPECT_EQ(budget->at(0, 0).failure, ErrorCode::kSearchBudgetExhausted);

  const std::vector<Eigen::Vector3d> bad = {{2, std::nan(""), 0.3}};
  auto invalid = EstimateTravelCosts(graph(), Differential(), starts, bad, {}, 1.0, {});
  ASSERT_FALSE(invalid.ok());
  EXPECT_EQ(invalid.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(invalid.error().field, "goals_m[0].y");
}

// ---- The two-level hall: a ramp, a deck, and Plan to agree with ----------------------------

class TwoLevelHall : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    map_ = new PlanningMap(std::shared_ptr<const TerrainModel>(&test_util::TwoLevelScene(),
                                                               [](const TerrainModel*) {}));
  }
  static void TearDownTestSuite() { delete map_; }
  static const SurfaceGraph& GraphFor(const RobotProfile& profile) {
    static std::vector<std::shared_ptr<const SurfaceGraph>> kept;
    kept.push_back(map_->Graph(profile.Traversability()).value());
    return *kept.back();
  }

  static PlanningMap* map_;
  TwoLevelRampLayout layout_ = GetTwoLevelRampLayout();
};
PlanningMap* TwoLevelHall::map_ = nullptr;

TEST_F(TwoLevelHall, UpTheRampTakesAsLongAsDownAndTheVerticalBoundSlowsIt) {
  const Eigen::Vector3d floor = layout_.start_example_m + Eigen::Vector3d(0, 0, 0.3);
  const Eigen::Vector3d deck = layout_.goal_example_m + Eigen::Vector3d(0, 0, 0.3);
  const Eigen::Vector3d floor_far(layout_.room_x_max_m - 2, 2.5, 0.3);
  const std::vector<Eigen::Vector3d> points = {floor, deck, floor_far};
  RobotProfile profile = Differential();
  auto normal = EstimateTravelCosts(GraphFor(profile), profile, points, points, {}, 1.0, {});
  ASSERT_TRUE(normal.ok()) << normal.error().message;
  // Both bounds, |vz| and |az| included, are the same up and down: so is the drive.
  const TravelCost& up = normal->at(0, 1);
  const TravelCost& down = normal->at(1, 0);
  ASSERT_TRUE(up.reachable() && down.reachable());
  EXPECT_NEAR(up.time_s, down.time_s, 0.01 * up.time_s);
  EXPECT_NEAR(up.length_m, down.length_m, 0.01 * up.length_m);
  // At 0.1 m/s vertically the 12° ramp can be driven at 0.1 / sin 12° = 0.48 m/s only.
  profile.max_speed_vertical_mps = 0.1;
  auto slow = EstimateTravelCosts(GraphFor(profile), profile, points, points, {}, 1.0, {});
  ASSERT_TRUE(slow.ok());
  const double ramp_length =
      (layout_.ramp_x_max_m - layout_.ramp_x_min_m) / std::cos(layout_.ramp_slope_rad);
  const double extra =
      ramp_length * (1 / (0.92 * 0.1 / std::sin(layout_.ramp_slope_rad)) - 1 / 0.92);
  EXPECT_GT(slow->at(0, 1).time_s, up.time_s + 0.8 * extra);
  EXPECT_NEAR(slow->at(0, 1).time_s, slow->at(1, 0).time_s, 0.01 * slow->at(0, 1).time_s);
  // Floor to floor never climbs: the vertical bound changes nothing there.
  EXPECT_NEAR(slow->at(0, 2).time_s, normal->at(0, 2).time_s, 1e-9);
}

TEST_F(TwoLevelHall, UnreachableCellsAreThoseThatPlanRefuses) {
  // A robot that may not climb the ramp: the deck is another component for it.
  RobotProfile profile = Differential();
  profile.max_tilt_rad = 0.6 * layout_.ramp_slope_rad;
  const SurfaceGraph& graph = GraphFor(profile);
  const std::vector<Eigen::Vector3d> starts = {layout_.start_example_m + Eigen::Vector3d(0, 0, 0.3),
                                               {layout_.room_x_max_m - 2, 9, 3.3}};
  const std::vector<Eigen::Vector3d> goals = {
      {3, 10, 3.3}, {layout_.room_x_max_m - 3, 2.5, 0.3}, {2, 10, 0.3}};
  auto matrix = EstimateTravelCosts(graph, profile, starts, goals, {}, 1.0, {});
  ASSERT_TRUE(matrix.ok()) << matrix.error().message;
  int unreachable = 0;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    for (std::size_t j = 0; j < goals.size(); ++j) {
      PlanRequest request;
      request.profile = profile;
      request.start.position_m = starts[i];
      request.goal.position_m = goals[j];
      request.options.max_attempts = 1;
      const Expected<PlanResult> plan = Plan(*map_, request);
      const bool plan_unreachable = !plan && plan.error().code == ErrorCode::kGoalUnreachable;
      EXPECT_EQ(matrix->at(i, j).failure == ErrorCode::kGoalUnreachable, plan_unreachable)
          << "start " << i << " goal " << j << ": "
          << (plan ? std::string("planned") : plan.error().message);
      unreachable += plan_unreachable;
    }
  }
  EXPECT_EQ(unreachable, 3);  // Deck to floor and floor to deck, both ways round.
}

TEST_F(TwoLevelHall, AZoneOnTheRampCutsTheDeckOffAsItDoesForPlan) {
  const RobotProfile profile = Differential();
  Prism zone;
  zone.polygon_m = {{layout_.ramp_x_min_m + 2, layout_.ramp_y_min_m - 1},
                    {layout_.ramp_x_min_m + 3, layout_.ramp_y_min_m - 1},
                    {layout_.ramp_x_min_m + 3, layout_.ramp_y_max_m + 1},
                    {layout_.ramp_x_min_m + 2, layout_.ramp_y_max_m + 1}};
  zone.z_min_m = -1;
  zone.z_max_m = 2.5;
  const std::vector<KeepOutZone> zones = {KeepOutZone(zone, "keep-out zone keep_out[0]")};
  const std::vector<Eigen::Vector3d> starts = {layout_.start_example_m +
                                               Eigen::Vector3d(0, 0, 0.3)};
  const std::vector<Eigen::Vector3d> goals = {layout_.goal_example_m + Eigen::Vector3d(0, 0, 0.3)};
  auto matrix = EstimateTravelCosts(GraphFor(profile), profile, starts, goals, zones, 1.0, {});
  ASSERT_TRUE(matrix.ok()) << matrix.error().message;
  EXPECT_EQ(matrix->at(0, 0).failure, ErrorCode::kGoalUnreachable);
  PlanRequest request;
  request.profile = profile;
  request.start.position_m = starts[0];
  request.goal.position_m = goals[0];
  request.keep_out = {zone};
  const Expected<PlanResult> plan = Plan(*map_, request);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kGoalUnreachable);
}

// Ends snap as Plan snaps them (SnapEndpoint): only onto nodes whose reference point keeps
// the obstacle distance the verifier will ask of the trajectory.
TEST_F(TwoLevelHall, EndsSnapAsPlanDoesKeepingTheObstacleDistance) {
  const RobotProfile profile = Differential();
  const SurfaceGraph& graph = GraphFor(profile);
  const Eigen::Vector3d floor = layout_.start_example_m + Eigen::Vector3d(0, 0, 0.3);
  // The floor's node nearest an obstacle, and a distance it does not keep.
  const int component =
      graph.component(SnapEndpoint(graph, floor, 1.0, ErrorCode::kStartOffGround)->node);
  int tight = -1;
  for (int n = 0; n < graph.node_count(); ++n) {
    if (graph.component(n) != component) continue;
    if (tight < 0 || graph.clearance(n) < graph.clearance(tight)) tight = n;
  }
  // The reference point's clearance levels off above open floor (the ground itself is at
  // about the reference height): ask for half-way to the best within the tolerance.
  double best = 0;
  for (int n = 0; n < graph.node_count(); ++n) {
    if ((graph.position(n) - graph.position(tight)).norm() < 0.9) {
      best = std::max(best, graph.clearance(n));
    }
  }
  ASSERT_GT(best, graph.clearance(tight) + 0.005);
  const double keep = 0.5 * (graph.clearance(tight) + best);
  const Eigen::Vector3d near_wall = graph.position(tight);
  ASSERT_EQ(SnapToSurface(graph, near_wall, 1.0, ErrorCode::kStartOffGround)->node, tight);
  const Expected<SnapResult> snapped =
      SnapEndpoint(graph, near_wall, 1.0, ErrorCode::kStartOffGround, keep);
  ASSERT_TRUE(snapped.ok()) << snapped.error().message;
  EXPECT_NE(snapped->node, tight);
  EXPECT_GE(graph.clearance(snapped->node), keep);

  TravelCostConfig config;
  config.min_obstacle_distance_m = keep;
  const std::vector<Eigen::Vector3d> starts = {near_wall}, goals = {floor};
  Expected<TravelCostQuery> query =
      TravelCostQuery::Prepare(graph, profile, starts, goals, {}, 1.0, config);
  ASSERT_TRUE(query.ok()) << query.error().message;
  ASSERT_TRUE(query->starts()[0].ok());
  EXPECT_EQ(query->starts()[0]->node, snapped->node);
  EXPECT_EQ(query->starts()[0]->position_m, snapped->position_m);
  // Plan, its verifier asking the same distance, starts exactly there.
  PlanRequest request;
  request.profile = profile;
  request.start.position_m = near_wall;
  request.goal.position_m = floor;
  request.options.verifier.min_obstacle_distance_m = keep;
  const Expected<PlanResult> plan = Plan(*map_, request);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->start.node, snapped->node);
  EXPECT_EQ(plan->start.position_m, snapped->position_m);

  // No node within tolerance keeps 10 m: the end has no estimate, for Plan's reason.
  config.min_obstacle_distance_m = 10;
  query = TravelCostQuery::Prepare(graph, profile, starts, goals, {}, 1.0, config);
  ASSERT_TRUE(query.ok()) << query.error().message;
  ASSERT_FALSE(query->starts()[0].ok());
  EXPECT_EQ(query->starts()[0].error().code, ErrorCode::kStartOffGround);
  EXPECT_THAT(query->starts()[0].error().message, HasSubstr("min_obstacle_distance_m"));
  request.options.verifier.min_obstacle_distance_m = 10;
  const Expected<PlanResult> refused = Plan(*map_, request);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().message, query->starts()[0].error().message);
}

TEST_F(TwoLevelHall, SearchingNodeForNodeMatchesAStar) {
  const RobotProfile profile = Differential();
  const SurfaceGraph& graph = GraphFor(profile);
  std::mt19937 rng(11);
  const int component =
      graph.component(SnapToSurface(graph, layout_.start_example_m + Eigen::Vector3d(0, 0, 0.3),
                                    1.0, ErrorCode::kStartOffGround)
                          ->node);
  std::vector<int> nodes;
  for (int n = 0; n < graph.node_count(); ++n) {
    if (graph.component(n) == component) nodes.push_back(n);
  }
  std::vector<Eigen::Vector3d> starts, goals;
  for (int k = 0; k < 4; ++k) starts.push_back(graph.position(nodes[rng() % nodes.size()]));
  for (int k = 0; k < 6; ++k) goals.push_back(graph.position(nodes[rng() % nodes.size()]));
  TravelCostConfig exact;
  exact.coarse_cell_m = 0;  // The SurfaceGraph itself.
  SearchConfig plain;       // A* with w = 1 and no line bias: optimal, like Dijkstra.
  plain.heuristic_weight = 1;
  plain.line_bias = 0;
  auto matrix = EstimateTravelCosts(graph, profile, starts, goals, {}, 1.0, exact);
  auto coarse = EstimateTravelCosts(graph, profile, starts, goals, {}, 1.0, TravelCostConfig{});
  ASSERT_TRUE(matrix.ok() && coarse.ok());
  for (std::size_t i = 0; i < starts.size(); ++i) {
    for (std::size_t j = 0; j < goals.size(); ++j) {
      const int a = SnapEndpoint(graph, starts[i], 1.0, ErrorCode::kStartOffGround)->node;
      const int b = SnapEndpoint(graph, goals[j], 1.0, ErrorCode::kGoalOffGround)->node;
      const Expected<PathResult> path = SearchPath(graph, a, b, plain, {});
      ASSERT_TRUE(path.ok()) << path.error().message;
      const TravelCost& cell = matrix->at(i, j);
      ASSERT_TRUE(cell.reachable());
      EXPECT_NEAR(cell.search_cost, path->cost, 1e-4 * std::max(1.0, path->cost)) << i << j;
      // Equally cheap paths may differ a little in length where the clearance terms differ.
      EXPECT_NEAR(cell.search_length_m, path->length_m, 0.02 * path->length_m + 0.01) << i << j;
      // Merged blocks change the cost by a fraction of a block per bend.
      EXPECT_NEAR(coarse->at(i, j).search_cost, path->cost, 0.05 * path->cost + 0.5) << i << j;
    }
  }
}

}  // namespace
}  // namespace strata
