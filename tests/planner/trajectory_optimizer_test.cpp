// The optimiser on the hand-made yard (test_util::Yard): it converges on a simple problem, its
// objective's gradient wrt the decision variables (waypoints q, duration parameters τ) matches
// central differences block by block, it honours should_stop at once, and it reports its
// iterations within the budget.
#include "strata/planning/trajectory_optimizer.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "planning/trajectory_optimizer_internal.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/terrain_query.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/prism.hpp"
#include "strata/verification/trajectory_verifier.hpp"
#include "test_util/gradient_check.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

// The cost's parameters as Plan builds them.
CostParams ParamsFor(const RobotProfile& profile, const OptimizerConfig& config) {
  return CostParams{profile, config.cost};
}

// The yard's ground height at (x, y) [m]: the ramp's over its footprint, else the floor's.
double YardGround(const Eigen::Vector2d& xy) {
  if (xy.x() < 7 || xy.y() < 1 || xy.y() > 5) return 0;
  return std::min(xy.x() - 7, 3.0) * std::tan(test_util::kYardRampSlopeRad);
}

// The straight path of reference points 0.1 m apart from `from` to `to` (x, y) on the ground.
std::vector<Eigen::Vector3d> StraightPath(const Eigen::Vector2d& from, const Eigen::Vector2d& to,
                                          double reference_height_m) {
  std::vector<Eigen::Vector3d> path;
  const int steps = static_cast<int>(std::ceil((to - from).norm() / 0.1));
  for (int k = 0; k <= steps; ++k) {
    const Eigen::Vector2d xy = from + (to - from) * k / steps;
    path.emplace_back(xy.x(), xy.y(), YardGround(xy) + reference_height_m);
  }
  return path;
}

RobotState At(const Eigen::Vector3d& position_m) {
  RobotState state;
  state.position_m = position_m;
  return state;
}

// One planning problem on the yard: the graph and cost for a built-in profile, and the
// problem made from a straight path between two points of the floor. Not copyable: the cost
// refers to the graph.
struct Case {
  Case(const std::string& robot, const Eigen::Vector2d& from, const Eigen::Vector2d& to,
       const OptimizerConfig& config = {})
      : profile(BuiltinProfile(robot).value()),
        graph(SurfaceGraph::Build(test_util::YardModel(), profile.Traversability()).value()),
        cost(graph, config.weights, ParamsFor(profile, config)),
        path(StraightPath(from, to, profile.reference_height_m)),
        problem(MakeInitialProblem(cost, path, At(path.front()), At(path.back()), config)) {}
  Case(const Case&) = delete;
  Case& operator=(const Case&) = delete;

  RobotProfile profile;
  SurfaceGraph graph;
  TrajectoryCost cost;
  std::vector<Eigen::Vector3d> path;
  OptimizationProblem problem;
};

TEST(OptimizeTrajectory, ConvergesAcrossOpenFloorToAVerifiedTrajectory) {
  const OptimizerConfig config;
  const Case s("differential", {1, 1}, {5, 1.5}, config);
  Minco3 minco;
  const auto report = OptimizeTrajectory(s.cost, s.problem, config, {}, &minco);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_TRUE(report->converged);
  EXPECT_GE(report->iterations, 1);
  EXPECT_LT(report->iterations, config.max_iterations);
  EXPECT_GE(report->evaluations, report->iterations);
  EXPECT_LT(report->final_cost, report->initial_cost);
  EXPECT_NEAR(report->final_cost, report->final_terms.total(), 1e-9 * report->final_cost);
  // The boundary states are kept, and the result passes verification.
  EXPECT_LT((minco.Position(0) - s.problem.head_pva.col(0)).norm(), 1e-9);
  EXPECT_LT((minco.Position(minco.TotalDuration()) - s.problem.tail_pva.col(0)).norm(), 1e-9);
  VerificationReport verification;
  const Status verified =
      VerifyTrajectory(s.graph, s.profile, Trajectory::FromMinco(minco), {}, &verification);
  EXPECT_TRUE(verified.ok()) << verified.error().message;
  // Near the fastest the bounds allow on a straight run: accelerating to the speed bound and
  // braking from it take length / v + v / a at least.
  const double length = (s.path.back() - s.path.front()).norm();
  const double v = s.profile.max_speed_horizontal_mps, a = s.profile.max_accel_horizontal_mps2;
  EXPECT_LT(minco.TotalDuration(), 1.3 * (length / v + v / a));
}

// J_k alone moves a trajectory out of a keep-out zone its initial path runs straight through
// (A* would have gone around; here the optimiser must): every dense sample ends outside the
// zone grown by the footprint radius, and the result passes verification against the zone.
TEST(OptimizeTrajectory, PushesTheTrajectoryOutOfAKeepOutZoneOnItsPath) {
  const OptimizerConfig config;
  const RobotProfile profile = BuiltinProfile("differential").value();
  const SurfaceGraph graph =
      SurfaceGraph::Build(test_util::YardModel(), profile.Traversability()).value();
  // Open floor between the slab (x <= 4) and the ramp (x >= 7); the path runs north along
  // x = 4.5, 0.1 m inside the zone's east edge, so J_k pushes it east, away from the slab.
  const Prism zone = BoxPrism(
      Eigen::AlignedBox3d(Eigen::Vector3d(3.8, 2.8, -0.5), Eigen::Vector3d(4.6, 3.4, 2.0)));
  const std::vector<KeepOutZone> zones = {KeepOutZone(zone, "keep-out zone keep_out[0]")};
  const TrajectoryCost cost(graph, config.weights, ParamsFor(profile, config), zones);
  const std::vector<Eigen::Vector3d> path =
      StraightPath({4.5, 0.8}, {4.5, 5.4}, profile.reference_height_m);
  const OptimizationProblem problem =
      MakeInitialProblem(cost, path, At(path.front()), At(path.back()), config);
  Minco3 minco;
  const auto report = OptimizeTrajectory(cost, problem, config, {}, &minco);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const Trajectory trajectory = Trajectory::FromMinco(minco);
  for (double t = 0; t <= trajectory.TotalDuration(); t += 0.01) {
    const Eigen::Vector3d p = trajectory.Position(t).head<3>();
    EXPECT_GE(zone.SignedDistanceXY(p.head<2>()), profile.footprint_radius_m)
        << "t = " << t << ": " << p.transpose();
  }
  VerificationReport verification;
  const Status verified = VerifyTrajectory(graph, profile, trajectory, {}, &verification, zones);
  EXPECT_TRUE(verified.ok()) << verified.error().message;
}

// The objective L-BFGS sees, J(q, T(τ)), against central differences over x = [q, τ], one
// block per waypoint axis and one for τ. On the ramp (slope, rim and safety terms) and under
// the slab (ceiling and body-height terms for the biped), from a perturbed initial guess.
class OptimizerObjectiveGradient : public ::testing::TestWithParam<std::string> {};

TEST_P(OptimizerObjectiveGradient, MatchesCentralDifferencesPerBlock) {
  const std::string robot = GetParam();
  const bool biped = robot == "biped";
  OptimizerConfig config;
  config.piece_length_m = 0.6;
  const Case s(robot, biped ? Eigen::Vector2d(1.5, 3.2) : Eigen::Vector2d(7.3, 1.6),
               biped ? Eigen::Vector2d(4.5, 2.8) : Eigen::Vector2d(9.5, 4.4), config);
  const int dim = s.problem.head_pva.rows();
  const int pieces = static_cast<int>(s.problem.initial_durations.size());
  ASSERT_GE(pieces, 3);
  Minco3 minco;
  minco.SetConditions(s.problem.head_pva, s.problem.tail_pva, pieces);
  internal::OptimizerObjective objective(s.cost, &minco, {});
  Eigen::VectorXd x = internal::InitialDecisionVector(s.problem);
  // Off the initial guess: waypoints moved by up to 5 cm, durations by up to 20%.
  for (Eigen::Index i = 0; i < x.size(); ++i)
    x(i) += (i % 2 == 0 ? 1 : -1) * (i < x.size() - pieces ? 0.05 : 0.2) * std::sin(i + 1.0);
  Eigen::VectorXd analytic;
  const double value = objective(x, analytic);
  const double h = 1e-6;
  const Eigen::VectorXd numeric = test_util::NumericalGradient(
      [&](const Eigen::VectorXd& y) {
        Eigen::VectorXd unused;
        return objective(y, unused);
      },
      x, h);
  // Waypoints are stored waypoint by waypoint: reorder them axis by axis.
  const int nq = dim * (pieces - 1);
  const auto by_axis = [&](const Eigen::VectorXd& g) {
    return test_util::WaypointsByAxis(g, dim, pieces - 1);
  };
  const std::vector<test_util::GradientBlock> blocks =
      test_util::WaypointAxisBlocks(dim, pieces - 1, "tau", pieces);
  EXPECT_TRUE(test_util::GradientsMatchPerBlock(by_axis(analytic), by_axis(numeric), blocks, 1e-5,
                                                test_util::FiniteDifferenceNoise(value, h)));
  // Every block must carry a gradient, or the comparison is 0 = 0.
  for (const auto& b : blocks) {
    EXPECT_GT(by_axis(analytic).segment(b.offset, b.size).norm(), 1e-3) << b.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, OptimizerObjectiveGradient,
                         ::testing::Values("differential", "biped"));

// Pinned waypoints (a route's flow-through vias): the objective's gradient of their x, y, z
// is exactly zero, every other component (their body height included) still matches central
// differences, and the pinned ones would not be zero unpinned.
TEST(OptimizerObjective, PinnedWaypointsHaveZeroPositionGradientAndTheRestStillMatches) {
  OptimizerConfig config;
  config.piece_length_m = 0.6;
  const Case s("biped", {1.5, 3.2}, {4.5, 2.8}, config);  // dim 4: a free body-height row.
  const int dim = s.problem.head_pva.rows();
  const int pieces = static_cast<int>(s.problem.initial_durations.size());
  ASSERT_GE(pieces, 4);
  const std::vector<int> pinned = {1, pieces - 3};
  Minco3 minco;
  minco.SetConditions(s.problem.head_pva, s.problem.tail_pva, pieces);
  internal::OptimizerObjective objective(s.cost, &minco, {}, pinned);
  Eigen::VectorXd x = internal::InitialDecisionVector(s.problem);
  for (Eigen::Index i = 0; i < x.size(); ++i)
    x(i) += (i % 2 == 0 ? 1 : -1) * (i < x.size() - pieces ? 0.05 : 0.2) * std::sin(i + 1.0);
  Eigen::VectorXd analytic;
  const double value = objective(x, analytic);
  const double h = 1e-6;
  Eigen::VectorXd numeric = test_util::NumericalGradient(
      [&](const Eigen::VectorXd& y) {
        Eigen::VectorXd unused;
        return objective(y, unused);
      },
      x, h);
  for (const int column : pinned) {
    for (int row = 0; row < 3; ++row) {
      const Eigen::Index i = Eigen::Index{column} * dim + row;
      EXPECT_EQ(analytic(i), 0.0) << "column " << column << " row " << row;
      EXPECT_GT(std::abs(numeric(i)), 1e-6) << "the pinned component carries a gradient unpinned";
      numeric(i) = 0;  // What pinning promises; the rest must match as before.
    }
    EXPECT_GT(std::abs(analytic(Eigen::Index{column} * dim + 3)), 1e-6) << "body height is free";
  }
  const auto by_axis = [&](const Eigen::VectorXd& g) {
    return test_util::WaypointsByAxis(g, dim, pieces - 1);
  };
  EXPECT_TRUE(test_util::GradientsMatchPerBlock(
      by_axis(analytic), by_axis(numeric),
      test_util::WaypointAxisBlocks(dim, pieces - 1, "tau", pieces), 1e-5,
      test_util::FiniteDifferenceNoise(value, h)));
}

// A pinned path point becomes a waypoint exactly (even mid-run, off any corner), and the
// optimiser leaves it exactly there while it moves the others.
TEST(OptimizeTrajectory, KeepsPinnedWaypointsExactlyWhereThePathPutsThem) {
  const OptimizerConfig config;
  const RobotProfile profile = BuiltinProfile("differential").value();
  const SurfaceGraph graph =
      SurfaceGraph::Build(test_util::YardModel(), profile.Traversability()).value();
  const TrajectoryCost cost(graph, config.weights, ParamsFor(profile, config));
  // Along the floor with a dog-leg, a via 13 points (1.3 m) along the first run.
  std::vector<Eigen::Vector3d> path = StraightPath({1, 1}, {5, 1.5}, profile.reference_height_m);
  const std::vector<Eigen::Vector3d> second =
      StraightPath({5, 1.5}, {5.5, 5.5}, profile.reference_height_m);
  path.insert(path.end(), second.begin() + 1, second.end());
  const std::vector<std::size_t> vias = {13};
  const OptimizationProblem problem =
      MakeInitialProblem(cost, path, At(path.front()), At(path.back()), config, vias);
  ASSERT_EQ(problem.pinned_waypoints.size(), 1u);
  const int column = problem.pinned_waypoints[0];
  EXPECT_EQ(Eigen::Vector3d(problem.initial_waypoints.col(column).head<3>()), path[13]);
  Minco3 minco;
  const auto report = OptimizeTrajectory(cost, problem, config, {}, &minco);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const Trajectory trajectory = Trajectory::FromMinco(minco);
  const TrajectoryPiece& after = trajectory.pieces[static_cast<std::size_t>(column) + 1];
  EXPECT_LT((after.coefficients.row(0).transpose() - path[13]).norm(), 1e-9);
  double moved = 0;  // The free waypoints did move.
  for (int k = 0; k < problem.initial_waypoints.cols(); ++k) {
    if (k == column) continue;
    const Eigen::Vector3d now =
        trajectory.pieces[static_cast<std::size_t>(k) + 1].coefficients.row(0).transpose();
    moved = std::max(moved, (now - problem.initial_waypoints.col(k).head<3>()).norm());
  }
  EXPECT_GT(moved, 1e-3);
  // The fallback keeps every path point; pinned_waypoints says where the via's is.
  const OptimizationProblem fallback =
      MakeFallbackProblem(cost, path, At(path.front()), At(path.back()),
                          VerifierConfig{}.min_obstacle_distance_m, vias);
  ASSERT_EQ(fallback.pinned_waypoints.size(), 1u);
  EXPECT_EQ(Eigen::Vector3d(fallback.initial_waypoints.col(fallback.pinned_waypoints[0]).head<3>()),
            path[13]);
}

TEST(OptimizeTrajectory, StopsAtThePollThatAsks) {
  const OptimizerConfig config;
  const Case s("differential", {1, 1}, {5, 1.5}, config);
  for (const int fire_at : {1, 5}) {
    int polls = 0;
    Minco3 minco;
    const auto report = OptimizeTrajectory(
        s.cost, s.problem, config, [&] { return ++polls >= fire_at; }, &minco);
    ASSERT_FALSE(report.ok());
    EXPECT_EQ(report.error().code, ErrorCode::kCancelled);
    EXPECT_EQ(polls, fire_at) << "no evaluation after the stop";
  }
}

TEST(OptimizeTrajectory, ReportsItsIterationsWithinTheBudget) {
  // What the problem needs with the default budget; every budget below it runs out.
  Minco3 unlimited_minco;
  const Case unlimited("differential", {1, 1}, {5, 1.5}, OptimizerConfig{});
  const auto needed = OptimizeTrajectory(unlimited.cost, unlimited.problem, OptimizerConfig{}, {},
                                         &unlimited_minco);
  ASSERT_TRUE(needed.ok()) << needed.error().message;
  ASSERT_TRUE(needed->converged);
  ASSERT_GT(needed->iterations, 3);
  for (const int budget : {1, 3, needed->iterations - 1}) {
    OptimizerConfig config;
    config.max_iterations = budget;
    const Case s("differential", {1, 1}, {5, 1.5}, config);
    Minco3 minco;
    const auto report = OptimizeTrajectory(s.cost, s.problem, config, {}, &minco);
    ASSERT_TRUE(report.ok()) << report.error().message;
    EXPECT_GE(report->iterations, 1) << budget;
    EXPECT_LE(report->iterations, budget);
    EXPECT_FALSE(report->converged) << "the problem needs more than " << budget << " iterations";
    EXPECT_LE(report->final_cost, report->initial_cost);
  }
}

TEST(MakeInitialProblem, SplitsThePathIntoPiecesAtTheBodyHeightTheCeilingAllows) {
  OptimizerConfig config;
  config.piece_length_m = 0.5;
  // The biped from the open floor under the slab (clearance 0.45 m).
  const Case s("biped", {0.5, 3}, {3.5, 3}, config);
  const OptimizationProblem& p = s.problem;
  // 3 m in pieces of 0.5 m, the first and the last split in two (from rest, to rest).
  ASSERT_EQ(p.initial_durations.size(), 8);
  ASSERT_EQ(p.initial_waypoints.rows(), 4);
  ASSERT_EQ(p.initial_waypoints.cols(), 7);
  EXPECT_EQ(p.held_waypoints, (std::vector<int>{0, 6}));
  EXPECT_TRUE((p.initial_durations.array() > 0).all());
  EXPECT_EQ(p.head_pva.col(0).head<3>(), Eigen::Vector3d(0.5, 3, 0.2));
  EXPECT_EQ(p.tail_pva.col(0).head<3>(), Eigen::Vector3d(3.5, 3, 0.2));
  EXPECT_TRUE(p.head_pva.rightCols<2>().isZero());
  // In the open the preferred 0.65 m; under the slab at most its clearance less headroom.
  EXPECT_NEAR(p.head_pva(3, 0), s.profile.body_height_m, 1e-9);
  EXPECT_LE(p.tail_pva(3, 0), 0.45 - s.profile.headroom_m + 1e-6);
  const std::vector<double> xs = {0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.25};
  for (int k = 0; k < p.initial_waypoints.cols(); ++k) {
    EXPECT_NEAR(p.initial_waypoints(0, k), xs[static_cast<std::size_t>(k)], 1e-6) << k;
  }
}

// From rest, one polynomial over a whole piece is too stiff to speed up at anything near the
// acceleration bound: the piece next to an end at rest is split, its middle held on the path.
// 11 m along the yard's floor from rest to rest take 1.20 times the time of driving them at
// the speed bound (1.26 without the split; the check leaves room for rounding between builds).
TEST(OptimizeTrajectory, FromRestToRestTheEndPiecesAreSplitAndTheTrajectoryNearlyTimeOptimal) {
  const OptimizerConfig config;
  const Case s("differential", {0.5, 0.5}, {11.5, 0.5}, config);
  const OptimizationProblem& p = s.problem;
  const int last = static_cast<int>(p.initial_waypoints.cols()) - 1;
  ASSERT_EQ(p.held_waypoints, (std::vector<int>{0, last}));
  EXPECT_TRUE(p.pinned_waypoints.empty());
  // Halfway along the first and the last piece (11 m in 7 pieces).
  EXPECT_NEAR(p.initial_waypoints(0, 0), 0.5 + 0.5 * 11.0 / 7, 1e-6);
  EXPECT_NEAR(p.initial_waypoints(0, last), 11.5 - 0.5 * 11.0 / 7, 1e-6);
  Minco3 minco;
  const auto report = OptimizeTrajectory(s.cost, p, config, {}, &minco);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const Trajectory trajectory = Trajectory::FromMinco(minco);
  for (const int column : {0, last}) {  // Held exactly where they are.
    const Eigen::Vector3d at = trajectory.pieces[static_cast<std::size_t>(column) + 1]
                                   .coefficients.row(0)
                                   .transpose()
                                   .head<3>();
    EXPECT_LT((at - p.initial_waypoints.col(column).head<3>()).norm(), 1e-9) << column;
  }
  EXPECT_LE(trajectory.TotalDuration(), 1.22 * 11.0 / s.profile.max_speed_horizontal_mps);

  // Already moving at the start: only the end at rest is split.
  RobotState moving = At(s.path.front());
  moving.velocity_mps = Eigen::Vector3d(0.9, 0, 0);
  const OptimizationProblem from_moving =
      MakeInitialProblem(s.cost, s.path, moving, At(s.path.back()), config);
  EXPECT_EQ(from_moving.held_waypoints,
            (std::vector<int>{static_cast<int>(from_moving.initial_waypoints.cols()) - 1}));
}

// The biped under the yard's slab (clearance 0.45 m, so a body of at most 0.40 m): the
// fallback's minimum-jerk curve keeps the body under the ceiling with its headroom and within
// its range at every instant (the verifier's body checks, to 0.1 mm where they allow 7 mm),
// crouching before the slab's edge instead of at it.
TEST(MakeFallbackProblem, CrouchesBeforeACeilingAndKeepsTheBodyWithinItsBounds) {
  const Case s("biped", {0.5, 3}, {5.5, 3});
  const RobotProfile& profile = s.profile;
  const OptimizationProblem fallback =
      MakeFallbackProblem(s.cost, s.path, At(s.path.front()), At(s.path.back()),
                          VerifierConfig{}.min_obstacle_distance_m);
  Minco3 minco;
  minco.SetConditions(fallback.head_pva, fallback.tail_pva,
                      static_cast<int>(fallback.initial_durations.size()));
  minco.SetParameters(fallback.initial_waypoints, fallback.initial_durations);
  const Trajectory trajectory = Trajectory::FromMinco(minco);
  double lowest_room = std::numeric_limits<double>::infinity();
  double body_at_edge = 0;  // At the slab's edge, x = 2.
  for (double t = 0; t <= trajectory.TotalDuration(); t += 0.005) {
    const StateVector p = trajectory.Position(t);
    GroundSample ground;
    ASSERT_TRUE(SampleGround(s.graph.model(), p.head<3>(), profile.reference_height_m,
                             s.cost.ClearanceCap(), &ground));
    EXPECT_GE(p(3), profile.body_height_min_m - 1e-4) << "t = " << t;
    EXPECT_LE(p(3), profile.body_height_max_m + 1e-4) << "t = " << t;
    lowest_room = std::min(lowest_room, ground.clearance_m - profile.headroom_m - p(3));
    if (std::abs(p(0) - 2) < 0.01) body_at_edge = p(3);
  }
  EXPECT_GE(lowest_room, -1e-4);
  EXPECT_LE(body_at_edge, 0.45 - profile.headroom_m + 1e-4);
}

// Stairs of 0.25 m risers and 0.6 m treads on a 0.3 m grid (a voxel map's stepped ramp): the
// ground interpolated between columns passes under each step's edge, and a point at the
// reference height above it comes nearer to the edge than the verifier allows. The fallback
// lifts such points, by at most 5 cm, to where they are clear.
TEST(MakeFallbackProblem, LiftsItsPointsClearOfTheStepEdgesTheInterpolatedGroundPassesUnder) {
  constexpr double kRise = 0.25, kTread = 0.6, kClearance = 0.05;
  const auto stairs_z = [](double x) {
    return x < 2 ? 0.0 : std::min(std::floor((x - 2) / kTread + 1), 6.0) * kRise;
  };
  test_util::CloudBuilder cloud(0.05);
  cloud.Surface(0, 8, 0, 3, [&](double x, double) { return stairs_z(x); });
  AssessmentConfig assessment;
  assessment.grid.resolution_m = 0.3;
  const auto model = TerrainModel::Assess(cloud.cloud(), assessment).value();
  const RobotProfile profile = BuiltinProfile("differential").value();
  const SurfaceGraph graph = SurfaceGraph::Build(*model, profile.Traversability()).value();
  const OptimizerConfig config;
  const TrajectoryCost cost(graph, config.weights, ParamsFor(profile, config));
  const double h_ref = profile.reference_height_m;
  // The interpolated ground's height + h_ref at (x, 1.5), the surface picked near the stairs'.
  const auto on_ground = [&](double x) {
    GroundSample ground;
    const Eigen::Vector3d guess(x, 1.5, stairs_z(x) + h_ref);
    EXPECT_TRUE(SampleGround(*model, guess, h_ref, 0, &ground));
    return Eigen::Vector3d(x, 1.5, ground.height_m + h_ref);
  };
  // The path on that ground, and again 8 cm above it, as a node's height can be (the ground
  // of its whole column): the fallback's points come down to the interpolated ground either way.
  std::vector<Eigen::Vector3d> path, raised;
  for (double x = 0.45; x < 7.6; x += 0.3) {
    path.push_back(on_ground(x));
    raised.emplace_back(path.back() + Eigen::Vector3d(0, 0, 0.08));
  }
  double nearest_on_ground = std::numeric_limits<double>::infinity();
  for (const std::vector<Eigen::Vector3d>& given : {path, raised}) {
    const OptimizationProblem fallback =
        MakeFallbackProblem(cost, given, At(path.front()), At(path.back()), kClearance);
    for (int k = 0; k < fallback.initial_waypoints.cols(); ++k) {
      const Eigen::Vector3d p = fallback.initial_waypoints.col(k).head<3>();
      const Eigen::Vector3d ground = on_ground(p.x());
      nearest_on_ground = std::min(nearest_on_ground, model->Distance(ground));
      const double lift = p.z() - ground.z();
      EXPECT_GE(lift, -1e-9) << p.transpose();
      EXPECT_LE(lift, 0.05 + 1e-9) << p.transpose();
      EXPECT_GE(model->Distance(p), kClearance) << p.transpose();
    }
  }
  // Without the lift, some point would fail the verifier's distance.
  EXPECT_LT(nearest_on_ground, kClearance);
}

TEST(OptimizerConfig, ValidateNamesEachFieldOutOfRange) {
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<std::string, std::function<void(OptimizerConfig*)>>> cases = {
      {"optimizer.weights.safety", [&](OptimizerConfig* c) { c->weights.safety = -1; }},
      {"optimizer.cost.safety_threshold",
       [&](OptimizerConfig* c) { c->cost.safety_threshold = nan; }},
      {"optimizer.cost.edge_margin_m", [&](OptimizerConfig* c) { c->cost.edge_margin_m = -0.1; }},
      {"optimizer.cost.distance_threshold_m",
       [&](OptimizerConfig* c) { c->cost.distance_threshold_m = 0; }},
      {"optimizer.cost.limit_margin", [&](OptimizerConfig* c) { c->cost.limit_margin = 1.5; }},
      {"optimizer.cost.body_height_margin_m",
       [&](OptimizerConfig* c) { c->cost.body_height_margin_m = inf; }},
      {"optimizer.cost.body_height_stiffness",
       [&](OptimizerConfig* c) { c->cost.body_height_stiffness = -1; }},
      {"optimizer.cost.samples_per_piece",
       [&](OptimizerConfig* c) { c->cost.samples_per_piece = 1; }},
      {"optimizer.piece_length_m", [&](OptimizerConfig* c) { c->piece_length_m = 0; }},
      {"optimizer.max_iterations", [&](OptimizerConfig* c) { c->max_iterations = 0; }},
      {"optimizer.gradient_tolerance", [&](OptimizerConfig* c) { c->gradient_tolerance = 0; }},
      {"optimizer.relative_improvement_tolerance",
       [&](OptimizerConfig* c) { c->relative_improvement_tolerance = -1; }},
      {"optimizer.memory", [&](OptimizerConfig* c) { c->memory = 0; }},
  };
  EXPECT_TRUE(OptimizerConfig{}.Validate().ok());
  for (const auto& [field, spoil] : cases) {
    OptimizerConfig config;
    spoil(&config);
    const Status status = config.Validate();
    ASSERT_FALSE(status.ok()) << field;
    EXPECT_EQ(status.error().code, ErrorCode::kInvalidConfig);
    EXPECT_THAT(status.error().message, HasSubstr(field + " = ")) << field;
    EXPECT_EQ(status.error().field, field);
  }
  // OptimizeTrajectory refuses a bad config before touching the trajectory.
  OptimizerConfig bad;
  bad.memory = 0;
  const Case s("differential", {1, 1}, {5, 1.5});
  Minco3 minco;
  const auto report = OptimizeTrajectory(s.cost, s.problem, bad, {}, &minco);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kInvalidConfig);
}

}  // namespace
}  // namespace strata
