#include "strata/planning/trajectory_costs.hpp"

#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/minco.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/gradient_check.hpp"
#include "test_util/terrain_queries.hpp"
#include "test_util/two_level_scene.hpp"

namespace strata {
namespace {

using test_util::GradientBlock;
using test_util::GradientsMatchPerBlock;
using test_util::NumericalGradient;

constexpr double kTolerance = 1e-5;
constexpr double kStep = 1e-7;  // Central differences' step.

double NoiseFloor(double f) { return test_util::FiniteDifferenceNoise(f, kStep); }

// The two-level scene: every term has something to bite on.
const TerrainModel& Scene() { return test_util::TwoLevelScene(); }

// Its traversable ground for a robot with the cost's reference height (J_e needs it).
const SurfaceGraph& Graph() {
  static const SurfaceGraph graph = [] {
    TraversabilityParams params;
    params.reference_height_m = 0.3;
    params.body_height_m = 0.4;
    return SurfaceGraph::Build(Scene(), params).value();
  }();
  return graph;
}

// Every weight zero (aggregate order: smoothness, time, safety, edge, ground, feasibility,
// height, keep_out, turning); a test turns on the terms it checks.
constexpr CostWeights kNoTerms{0, 0, 0, 0, 0, 0, 0, 0, 0};

// Each term alone, then all together.
struct TermCase {
  std::string name;
  CostWeights weights;
};
std::vector<TermCase> TermCases() {
  const CostWeights none = kNoTerms;
  std::vector<TermCase> cases;
  CostWeights w = none;
  w.smoothness = 1;
  cases.push_back({"smoothness", w});
  w = none;
  w.time = 3;
  cases.push_back({"time", w});
  w = none;
  w.safety = 50;
  cases.push_back({"safety", w});
  w = none;
  w.edge = 1e3;
  cases.push_back({"edge", w});
  w = none;
  w.ground = 20;
  cases.push_back({"ground", w});
  w = none;
  w.feasibility = 5;
  cases.push_back({"feasibility", w});
  w = none;
  w.height = 7;
  cases.push_back({"height", w});
  w = none;
  w.turning = 4;
  cases.push_back({"turning", w});
  cases.push_back({"all", CostWeights{}});
  return cases;
}

CostParams Params(bool active_height) {
  CostParams p;
  p.config.safety_threshold = 0.05;      // Low, so S' exceeds it on the ramp's edges and pillars.
  p.config.distance_threshold_m = 0.35;  // High, so the ESDF term is active near the ground.
  p.config.edge_margin_m = 0.6;          // High, so J_e is active well inside the ramp too.
  p.config.limit_margin = 1;
  p.config.samples_per_piece = 6;
  RobotProfile& robot = p.profile;
  robot.reference_height_m = 0.3;
  robot.max_speed_horizontal_mps = 0.8;
  robot.max_speed_vertical_mps = 0.2;
  robot.max_accel_horizontal_mps2 = 0.6;
  robot.max_accel_vertical_mps2 = 0.2;
  robot.active_height = active_height;
  robot.body_height_min_m = 0.35;
  robot.body_height_max_m = 0.7;
  robot.body_height_m = 0.65;  // Preferred, when active.
  robot.headroom_m = 0.05;
  return p;
}

// A point near the ground of the scene: on the ramp or under the deck, off the reference
// height by a few centimetres, with a body height from crouched to beyond the range.
StateVector RandomPosition(std::mt19937& rng, int dim) {
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  std::uniform_real_distribution<double> unit(0, 1);
  StateVector pos(dim);
  pos(0) = l.ramp_x_min_m - 1 + unit(rng) * (l.ramp_x_max_m - l.ramp_x_min_m + 2);
  pos(1) = l.ramp_y_min_m - 1 + unit(rng) * (l.ramp_y_max_m - l.ramp_y_min_m + 2);
  const auto ground = test_util::GroundHeightBelow(Scene(), {pos(0), pos(1), l.deck_z_m - 0.5});
  pos(2) = ground.value_or(l.floor_z_m) + 0.3 + 0.1 * (unit(rng) - 0.5);
  if (dim == 4) pos(3) = 0.25 + 0.6 * unit(rng);
  return pos;
}

class PointPenaltyGradient : public ::testing::TestWithParam<int> {};

TEST_P(PointPenaltyGradient, MatchesFiniteDifferencesForEveryTerm) {
  const int dim = GetParam();
  std::mt19937 rng(7 + dim);
  std::uniform_real_distribution<double> symmetric(-1.5, 1.5);
  for (const TermCase& term : TermCases()) {
    const TrajectoryCost cost(Graph(), term.weights, Params(dim == 4));
    int active = 0;
    for (int trial = 0; trial < 40; ++trial) {
      const StateVector pos = RandomPosition(rng, dim);
      StateVector vel(dim), acc(dim);
      for (int a = 0; a < dim; ++a) vel(a) = symmetric(rng), acc(a) = symmetric(rng);
      PointGradient gradient(dim);
      const double value = cost.PointPenalty({pos, vel, acc}, &gradient, nullptr);
      if (value > 0) ++active;

      // x = [pos, vel, acc].
      Eigen::VectorXd x(3 * dim);
      x << pos, vel, acc;
      const auto f = [&](const Eigen::VectorXd& y) {
        PointGradient ignored(dim);
        const StateVector p = y.segment(0, dim), v = y.segment(dim, dim),
                          a = y.segment(2 * dim, dim);
        return cost.PointPenalty({p, v, a}, &ignored, nullptr);
      };
      Eigen::VectorXd analytic(3 * dim);
      analytic << gradient.pos, gradient.vel, gradient.acc;
      const Eigen::VectorXd numeric = NumericalGradient(f, x, kStep);
      EXPECT_TRUE(GradientsMatchPerBlock(
          analytic, numeric,
          {{"position", 0, dim}, {"velocity", dim, dim}, {"acceleration", 2 * dim, dim}},
          kTolerance, NoiseFloor(value)))
          << term.name << " trial " << trial << " f " << value;
    }
    // The point terms must actually have been exercised (smoothness and time have none).
    if (term.name != "smoothness" && term.name != "time" && !(term.name == "height" && dim == 3)) {
      EXPECT_GT(active, 10) << term.name;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Dims, PointPenaltyGradient, ::testing::Values(3, 4));

// Where the room between the lowest body and the ceiling is less than twice the body-height
// margin, the margin shrinks with the room: its gradient through the clearance is checked
// there. A body whose lowest height nearly fills the space under the deck makes such room.
TEST(PointPenaltyGradientNearACeiling, MatchesFiniteDifferencesWhereTheMarginShrinks) {
  CostWeights feasibility_only = kNoTerms;
  feasibility_only.feasibility = 1e3;
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  CostParams params = Params(true);
  params.config.body_height_margin_m = 0.15;
  RobotProfile& robot = params.profile;
  robot.body_height_min_m = l.deck_underside_z_m - l.floor_z_m - robot.headroom_m - 0.15;
  robot.body_height_max_m = robot.body_height_min_m + 1;
  robot.body_height_m = robot.body_height_min_m + 0.5;
  const TrajectoryCost cost(Graph(), feasibility_only, params);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  int checked = 0;
  for (int draw = 0; draw < 20000 && checked < 20; ++draw) {
    StateVector pos = RandomPosition(rng, 4);
    GroundSample ground;
    if (!SampleGround(Scene(), pos.head<3>(), robot.reference_height_m, cost.ClearanceCap(),
                      &ground)) {
      continue;
    }
    const double room = ground.clearance_m - robot.headroom_m - robot.body_height_min_m;
    if (!(room > 0.01 && room < 2 * params.config.body_height_margin_m - 0.01)) continue;
    // A body height around the shrunken bounds, so that the low or ceiling penalty is active.
    pos(3) = robot.body_height_min_m + room * (1.5 * unit(rng) - 0.25);
    const StateVector zero = StateVector::Zero(4);
    PointGradient gradient(4);
    cost.PointPenalty({pos, zero, zero}, &gradient, nullptr);
    const auto f = [&](const Eigen::VectorXd& y) {
      PointGradient ignored(4);
      const StateVector q = y;
      return cost.PointPenalty({q, zero, zero}, &ignored, nullptr);
    };
    const Eigen::VectorXd numeric = NumericalGradient(f, pos, kStep);
    const double value = f(pos);
    EXPECT_TRUE(GradientsMatchPerBlock(gradient.pos, numeric,
                                       {{"xy", 0, 2}, {"z", 2, 1}, {"h", 3, 1}}, kTolerance,
                                       NoiseFloor(value)))
        << "room " << room;
    ++checked;
  }
  EXPECT_GE(checked, 5) << "too few points with little room under the deck";
}

// J_k on an L-shaped zone over the ramp (a reflex corner and straight edges), at points all
// around it and at every height from well below the zone's range to well above: the gradient
// matches finite differences everywhere, and nothing is charged where the robot's height range
// is more than the margin away from the zone's.
TEST(KeepOutPenalty, MatchesFiniteDifferencesAndActsOnlyWhereTheZoneAppliesInHeight) {
  CostWeights keep_out_only = kNoTerms;
  keep_out_only.keep_out = 1e4;
  const Prism l_shape{{{5, 1}, {9, 1}, {9, 2.5}, {6.5, 2.5}, {6.5, 4.5}, {5, 4.5}}, 0.5, 1.5};
  const std::vector<KeepOutZone> zones = {KeepOutZone(l_shape, "keep-out zone keep_out[0]")};
  for (const bool active : {false, true}) {
    const CostParams params = Params(active);
    const TrajectoryCost cost(Graph(), keep_out_only, params, zones);
    const RobotProfile& robot = params.profile;
    const double margin = params.config.keep_out_margin_m;
    const int dim = params.dim();
    std::mt19937 rng(23);
    std::uniform_real_distribution<double> x(4.2, 9.8), y(0.2, 5.3), z(-0.6, 2.6);
    int charged = 0, fading = 0, other_storey = 0;
    for (int trial = 0; trial < 400; ++trial) {
      StateVector pos = StateVector::Zero(dim);
      pos.head<3>() << x(rng), y(rng), z(rng);
      if (dim == 4) pos(3) = 0.5;
      const StateVector zero = StateVector::Zero(dim);
      PointGradient gradient(3);
      CostBreakdown terms;
      const double value = cost.PointPenalty({pos, zero, zero}, &gradient, &terms);
      EXPECT_DOUBLE_EQ(terms.keep_out, value);
      const double overlap = KeepOutVerticalOverlap(l_shape, robot, pos(2));
      if (overlap <= -margin) {
        ++other_storey;
        EXPECT_EQ(value, 0) << pos.transpose();
        EXPECT_EQ(gradient.pos.norm(), 0) << pos.transpose();
        continue;
      }
      if (value > 0) ++charged;
      if (value > 0 && overlap < 0) ++fading;
      const auto f = [&](const Eigen::VectorXd& q) {
        PointGradient ignored(3);
        const StateVector state = q;
        return cost.PointPenalty({state, zero, zero}, &ignored, nullptr);
      };
      const Eigen::VectorXd numeric = NumericalGradient(f, pos, kStep);
      EXPECT_TRUE(GradientsMatchPerBlock(gradient.pos, numeric, {{"xy", 0, 2}, {"z", 2, dim - 2}},
                                         kTolerance, NoiseFloor(value)))
          << pos.transpose() << " overlap " << overlap;
    }
    // Every regime was visited: charged in height, within the fade, and on another storey.
    EXPECT_GT(charged, 40) << "active " << active;
    EXPECT_GT(fading, 3) << "active " << active;
    EXPECT_GT(other_storey, 40) << "active " << active;
  }
}

// A random MINCO trajectory along the ramp: J(q, T) through Evaluate and the adjoint.
struct Trajectory5 {
  Eigen::MatrixXd head, tail, waypoints;
  Eigen::VectorXd durations;
};

Trajectory5 RandomTrajectory(std::mt19937& rng, int dim, int pieces) {
  std::uniform_real_distribution<double> unit(0, 1);
  Trajectory5 t;
  t.head = Eigen::MatrixXd::Zero(dim, 3);
  t.tail = Eigen::MatrixXd::Zero(dim, 3);
  t.head.col(0) = RandomPosition(rng, dim);
  t.tail.col(0) = RandomPosition(rng, dim);
  t.head.col(1).setConstant(0.2);
  t.tail.col(2).setConstant(-0.1);
  t.waypoints.resize(dim, pieces - 1);
  for (int k = 0; k < pieces - 1; ++k) t.waypoints.col(k) = RandomPosition(rng, dim);
  t.durations.resize(pieces);
  for (int k = 0; k < pieces; ++k) t.durations(k) = 0.6 + 1.5 * unit(rng);
  return t;
}

double Objective(const TrajectoryCost& cost, const Trajectory5& t, const Eigen::MatrixXd& q,
                 const Eigen::VectorXd& durations) {
  Minco3 minco;
  minco.SetConditions(t.head, t.tail, static_cast<int>(durations.size()));
  minco.SetParameters(q, durations);
  Eigen::MatrixXd gc;
  Eigen::VectorXd gT;
  return cost.Evaluate(minco, &gc, &gT);
}

// The terms of a breakdown by the names TermCases uses.
std::vector<std::pair<std::string, double>> Terms(const CostBreakdown& b) {
  return {{"smoothness", b.smoothness}, {"time", b.time},
          {"safety", b.safety},         {"edge", b.edge},
          {"ground", b.ground},         {"feasibility", b.feasibility},
          {"height", b.height},         {"turning", b.turning}};
}

class ObjectiveGradient : public ::testing::TestWithParam<int> {};

TEST_P(ObjectiveGradient, WaypointAndDurationGradientsMatchFiniteDifferences) {
  const int dim = GetParam();
  const int pieces = 5;
  std::mt19937 rng(100 + dim);
  for (const TermCase& term : TermCases()) {
    const TrajectoryCost cost(Graph(), term.weights, Params(dim == 4));
    for (int trial = 0; trial < 4; ++trial) {
      const Trajectory5 t = RandomTrajectory(rng, dim, pieces);
      Minco3 minco;
      minco.SetConditions(t.head, t.tail, pieces);
      minco.SetParameters(t.waypoints, t.durations);
      Eigen::MatrixXd grad_c, grad_q;
      Eigen::VectorXd grad_T, grad_durations;
      CostBreakdown terms;
      const double value = cost.Evaluate(minco, &grad_c, &grad_T, &terms);
      EXPECT_NEAR(value, terms.total(), 1e-9 * std::max(1.0, value));
      minco.PropagateGradient(grad_c, grad_T, &grad_q, &grad_durations);

      const int nq = dim * (pieces - 1);
      Eigen::VectorXd x(nq + pieces);
      x << Eigen::Map<const Eigen::VectorXd>(t.waypoints.data(), nq), t.durations;
      const auto f = [&](const Eigen::VectorXd& y) {
        const Eigen::MatrixXd q = Eigen::Map<const Eigen::MatrixXd>(y.data(), dim, pieces - 1);
        return Objective(cost, t, q, y.tail(pieces));
      };
      Eigen::VectorXd analytic(nq + pieces);
      analytic << Eigen::Map<const Eigen::VectorXd>(grad_q.data(), nq), grad_durations;
      const Eigen::VectorXd numeric = NumericalGradient(f, x, kStep);
      // Blocks: each axis of the waypoints (x, y, z[, h]), then the durations. The waypoints
      // are stored waypoint by waypoint; reorder them axis by axis.
      const auto by_axis = [&](const Eigen::VectorXd& g) {
        return test_util::WaypointsByAxis(g, dim, pieces - 1);
      };
      const std::vector<test_util::GradientBlock> blocks =
          test_util::WaypointAxisBlocks(dim, pieces - 1, "durations", pieces);
      EXPECT_TRUE(GradientsMatchPerBlock(by_axis(analytic), by_axis(numeric), blocks, kTolerance,
                                         NoiseFloor(value)))
          << term.name << " trial " << trial << " f " << value;
      // Every term this case weighs must be active here, or its gradient is checked as 0 = 0
      // (the body-height term has no axis to act on in 3D).
      for (const auto& [name, term_value] : Terms(terms)) {
        const bool weighed =
            (term.name == name || term.name == "all") && !(name == "height" && dim == 3);
        if (weighed)
          EXPECT_GT(term_value, 0)
              << name << " inactive in case " << term.name << " trial " << trial;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Dims, ObjectiveGradient, ::testing::Values(3, 4));

// The S' part of J_s fades in over safety_fade_m from both ends: a trajectory whose ends lie
// where S' exceeds its threshold pays less for it than without the fade, and the ESDF part
// does not change.
TEST(SafetyFade, WeighsLessNearTheEndsAndLeavesTheObstacleDistanceAlone) {
  CostWeights safety_only = kNoTerms;
  safety_only.safety = 1e3;
  std::mt19937 rng(11);
  int compared = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Trajectory5 t = RandomTrajectory(rng, 3, 4);
    Minco3 minco;
    minco.SetConditions(t.head, t.tail, 4);
    minco.SetParameters(t.waypoints, t.durations);
    const auto safety = [&](double fade_m, double distance_stiffness) {
      CostParams params = Params(false);
      params.config.safety_fade_m = fade_m;
      params.config.distance_stiffness = distance_stiffness;
      const TrajectoryCost cost(Graph(), safety_only, params);
      Eigen::MatrixXd grad_c;
      Eigen::VectorXd grad_T;
      CostBreakdown terms;
      cost.Evaluate(minco, &grad_c, &grad_T, &terms);
      return terms.safety;
    };
    const double unfaded = safety(0, 0);
    if (unfaded <= 0) continue;
    ++compared;
    EXPECT_LT(safety(1.5, 0), unfaded) << trial;
    // Only the distance part left: the fade changes nothing.
    const double distance_part = safety(0, 30) - unfaded;
    EXPECT_NEAR(safety(1.5, 30) - safety(1.5, 0), distance_part,
                1e-9 * std::max(1.0, distance_part))
        << trial;
  }
  EXPECT_GT(compared, 10);
}

// J_ω is the heading's travel in x, y: a quarter circle driven at speed costs λ_ω·π/2 whether
// it turns left or right, less what smoothing |ω| takes off (at most ε = 0.05 rad/s over its
// 7.9 s, 0.39 rad); an S-bend of two quarter circles twice that (its turns do not cancel); a
// straight line nothing.
TEST(TurningCost, IsTheHeadingsTravelEitherWay) {
  CostWeights turning_only = kNoTerms;
  turning_only.turning = 3;
  const TrajectoryCost cost(Graph(), turning_only, Params(false));
  constexpr double kRadius = 4, kSpeed = 0.8, kQuarter = std::numbers::pi / 2;
  // A curve through points along the arcs (side +1 turns left, -1 right; turns[k] the side of
  // the k-th quarter), starting and ending along its tangent at kSpeed.
  const auto turning = [&](const std::vector<int>& turns) {
    constexpr int kPiecesPerQuarter = 8;
    std::vector<Eigen::Vector3d> points = {Eigen::Vector3d::Zero()};
    Eigen::Vector2d at = Eigen::Vector2d::Zero(), heading(1, 0);
    for (const int side : turns) {
      const Eigen::Vector2d normal(-heading.y() * side, heading.x() * side);
      const Eigen::Vector2d centre = at + kRadius * normal;
      for (int k = 1; k <= kPiecesPerQuarter; ++k) {
        const double angle = side * kQuarter * k / kPiecesPerQuarter;
        const Eigen::Rotation2Dd rotation(angle);
        const Eigen::Vector2d p = centre + rotation * (at - centre);
        points.emplace_back(p.x(), p.y(), 0);
      }
      at = points.back().head<2>();
      heading = Eigen::Rotation2Dd(side * kQuarter) * heading;
    }
    const int pieces = static_cast<int>(points.size()) - 1;
    Eigen::MatrixXd head = Eigen::MatrixXd::Zero(3, 3), tail = Eigen::MatrixXd::Zero(3, 3);
    head.col(1) << kSpeed, 0, 0;
    tail.col(0) = points.back();
    tail.col(1).head<2>() = kSpeed * heading;
    Eigen::MatrixXd waypoints(3, pieces - 1);
    for (int k = 1; k < pieces; ++k) waypoints.col(k - 1) = points[static_cast<std::size_t>(k)];
    const double piece_s = kRadius * kQuarter / kPiecesPerQuarter / kSpeed;
    Minco3 minco;
    minco.SetConditions(head, tail, pieces);
    minco.SetParameters(waypoints, Eigen::VectorXd::Constant(pieces, piece_s));
    Eigen::MatrixXd grad_c;
    Eigen::VectorXd grad_T;
    CostBreakdown terms;
    cost.Evaluate(minco, &grad_c, &grad_T, &terms);
    return terms.turning / turning_only.turning;
  };
  const double quarter = turning({+1});
  EXPECT_LE(quarter, 1.01 * kQuarter);
  EXPECT_GE(quarter, 0.97 * kQuarter - 0.05 * kRadius * kQuarter / kSpeed);
  EXPECT_NEAR(turning({-1}), quarter, 1e-9);
  // A little less than twice: where the heading's rate changes sign, |ω| is under ε.
  const double s_bend = turning({+1, -1});
  EXPECT_LE(s_bend, 2.02 * quarter);
  EXPECT_GE(s_bend, 1.85 * quarter);

  // Straight ahead, speeding up from 0.5 to 1 m/s: no turn, whatever the acceleration along.
  PointGradient gradient(3);
  const StateVector pos = Eigen::Vector3d(0, 0, 0.3), vel = Eigen::Vector3d(0.5, 0.5, 0),
                    acc = Eigen::Vector3d(0.3, 0.3, 0.1);
  EXPECT_EQ(cost.PointPenalty({pos, vel, acc}, &gradient, nullptr), 0.0);
}

// One evaluation of J: its value, gradients and terms.
struct Evaluation {
  double value = 0;
  Eigen::MatrixXd grad_c;
  Eigen::VectorXd grad_T;
  CostBreakdown terms;
};
// The trajectory of `minco` evaluated with *memo (which it updates) and fresh, without one.
struct BothWays {
  Evaluation with_memo, fresh;
};
BothWays EvaluateBothWays(const TrajectoryCost& cost, const Minco3& minco, TerrainMemo* memo) {
  BothWays e;
  e.with_memo.value =
      cost.Evaluate(minco, &e.with_memo.grad_c, &e.with_memo.grad_T, &e.with_memo.terms, memo);
  e.fresh.value = cost.Evaluate(minco, &e.fresh.grad_c, &e.fresh.grad_T, &e.fresh.terms);
  return e;
}

// TerrainMemo skips the S', d and rim lookups where it knows them to be zero. Along a walk of
// small steps, as L-BFGS takes them, the cost and gradient with it must equal a fresh
// evaluation's to the bit, and the walk must meet points it skips and points it cannot.
TEST(TerrainMemo, LeavesCostAndGradientUnchangedToTheBit) {
  for (const int dim : {3, 4}) {
    CostParams params = Params(dim == 4);
    params.config.safety_threshold = CostConfig{}.safety_threshold;
    params.config.distance_threshold_m = CostConfig{}.distance_threshold_m;
    params.config.edge_margin_m = CostConfig{}.edge_margin_m;
    const TrajectoryCost cost(Graph(), CostWeights{}, params);
    std::mt19937 rng(7 + dim);
    std::normal_distribution<double> step(0.0, 0.02);
    Trajectory5 t = RandomTrajectory(rng, dim, 6);
    TerrainMemo memo;
    int quiet_fields = 0, deep_inside = 0, neither = 0;
    for (int k = 0; k < 30; ++k) {
      Minco3 minco;
      minco.SetConditions(t.head, t.tail, 6);
      minco.SetParameters(t.waypoints, t.durations);
      const BothWays e = EvaluateBothWays(cost, minco, &memo);
      ASSERT_EQ(e.with_memo.value, e.fresh.value) << "step " << k;
      ASSERT_EQ(e.with_memo.terms.safety, e.fresh.terms.safety);
      ASSERT_EQ(e.with_memo.terms.edge, e.fresh.terms.edge);
      ASSERT_TRUE((e.with_memo.grad_c.array() == e.fresh.grad_c.array()).all()) << "step " << k;
      ASSERT_TRUE((e.with_memo.grad_T.array() == e.fresh.grad_T.array()).all()) << "step " << k;
      for (const TerrainMemo::Point& point : memo.points) {
        quiet_fields += point.quiet_field_block >= 0;
        deep_inside += point.deep_inside.ix >= 0;
        neither += point.quiet_field_block < 0 && point.deep_inside.ix < 0;
      }
      for (int i = 0; i < t.waypoints.cols(); ++i) {
        t.waypoints.col(i).head<2>() += Eigen::Vector2d(step(rng), step(rng));
      }
    }
    EXPECT_GT(quiet_fields, 100) << dim;
    EXPECT_GT(deep_inside, 100) << dim;
    EXPECT_GT(neither, 100) << dim;
  }
}

// With the body height fixed, TerrainMemo also skips the ground sample where its choice shows
// the ground within J_g's band. A walk over the floor, its waypoints within about a centimetre
// of the ground, must meet points it skips and points it cannot (off the band, or where the
// pieces swing onto the ramp), and get the fresh cost and gradient to the bit.
TEST(TerrainMemo, SkipsTheGroundSampleOnlyWhereJgIsZero) {
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  const CostParams params = Params(false);
  const double reference_m = params.profile.reference_height_m;
  const TrajectoryCost cost(Graph(), CostWeights{}, params);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0, 1);
  // A point over the floor, at the ground height the cost sees plus the reference height,
  // ±12 mm (J_g's band is ±10 mm).
  const auto on_floor = [&] {
    for (;;) {
      const double x = unit(rng) * l.room_x_max_m, y = unit(rng) * l.room_y_max_m;
      GroundSample ground;
      if (SampleGround(Scene(), {x, y, l.floor_z_m + reference_m}, reference_m, 0, &ground) &&
          std::abs(ground.height_m - l.floor_z_m) < 0.05) {
        return Eigen::Vector3d(x, y, ground.height_m + reference_m + 0.024 * (unit(rng) - 0.5));
      }
    }
  };
  const int pieces = 8;
  Trajectory5 t;
  t.head = Eigen::MatrixXd::Zero(3, 3);
  t.tail = Eigen::MatrixXd::Zero(3, 3);
  t.head.col(0) = on_floor();
  t.tail.col(0) = on_floor();
  t.waypoints.resize(3, pieces - 1);
  for (int k = 0; k < pieces - 1; ++k) t.waypoints.col(k) = on_floor();
  t.durations = Eigen::VectorXd::Constant(pieces, 4.0);
  std::normal_distribution<double> step(0.0, 0.01);
  TerrainMemo memo;
  int skipped = 0, sampled = 0;
  for (int k = 0; k < 30; ++k) {
    Minco3 minco;
    minco.SetConditions(t.head, t.tail, pieces);
    minco.SetParameters(t.waypoints, t.durations);
    // Which constraint points the memo will skip, from where Evaluate samples them (a piece's
    // first point is the previous one's last, evaluated once).
    const int kappa = params.config.samples_per_piece;
    if (!memo.points.empty()) {
      for (int i = 0; i < pieces; ++i) {
        const double start = minco.durations().head(i).sum();
        for (int j = i > 0 ? 1 : 0; j <= kappa; ++j) {
          const Eigen::Vector3d p = minco.Position(start + minco.durations()(i) * j / kappa);
          const bool skip = GroundWithinBand(memo.points[std::size_t(i) * (kappa + 1) + j].ground,
                                             p, reference_m, params.config.ground_band_m);
          (skip ? skipped : sampled) += 1;
        }
      }
    }
    const BothWays e = EvaluateBothWays(cost, minco, &memo);
    ASSERT_EQ(e.with_memo.value, e.fresh.value) << "step " << k;
    ASSERT_EQ(e.with_memo.terms.ground, e.fresh.terms.ground) << "step " << k;
    ASSERT_TRUE((e.with_memo.grad_c.array() == e.fresh.grad_c.array()).all()) << "step " << k;
    ASSERT_TRUE((e.with_memo.grad_T.array() == e.fresh.grad_T.array()).all()) << "step " << k;
    for (int i = 0; i < t.waypoints.cols(); ++i) {
      t.waypoints.col(i).head<2>() += Eigen::Vector2d(step(rng), step(rng));
    }
  }
  EXPECT_GT(skipped, 200) << sampled;
  EXPECT_GT(sampled, 200) << skipped;
}

TEST(SampleGroundOnTheRamp, FollowsTheRampAndFindsTheDeckAsCeiling) {
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  GroundSample s;
  // Mid-ramp: the ground rises along the ramp's uphill direction at its slope.
  const double x = 0.5 * (l.ramp_x_min_m + l.ramp_x_max_m);
  const double y = 0.5 * (l.ramp_y_min_m + l.ramp_y_max_m);
  const auto ground = test_util::GroundHeightBelow(Scene(), {x, y, l.deck_z_m - 0.3});
  ASSERT_TRUE(ground.has_value());
  ASSERT_TRUE(SampleGround(Scene(), {x, y, *ground + 0.3}, 0.3, 10, &s));
  EXPECT_NEAR(s.height_m, *ground, 0.1);
  const double slope = s.height_gradient.dot(l.ramp_uphill_dir);
  EXPECT_NEAR(std::atan(slope), l.ramp_slope_rad, 0.05);
  // Under the deck, the clearance is the height of the deck's underside above the floor.
  const Eigen::Vector2d under = l.pillar_centers_m.front() + Eigen::Vector2d(1.5, 0);
  ASSERT_TRUE(SampleGround(Scene(), {under.x(), under.y(), l.floor_z_m + 0.3}, 0.3, 10, &s));
  EXPECT_NEAR(s.clearance_m, l.deck_underside_z_m - l.floor_z_m, 0.25);
}

}  // namespace
}  // namespace strata
