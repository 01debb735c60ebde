// PolynomialTrajectory against hand-computed polynomials, a power-series reference and
// finite differences; piece timing, continuity, clamping and malformed input.
#include "strata/client/polynomial_trajectory.hpp"

#include <cmath>
#include <limits>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/v1/planner_service.pb.h"
#include "trajectory_builders.hpp"

namespace strata::client::testing {
namespace {

using ::testing::HasSubstr;

PolynomialTrajectory Build(const v1::Trajectory& proto) {
  auto result = PolynomialTrajectory::FromProto(proto);
  EXPECT_TRUE(result.ok()) << result.error().message;
  return std::move(result).value();
}

// x = 1 + 2t + 3t² + 4t³ + 5t⁴ + 6t⁵, y = −t³, z = 0.5, one piece of 2 s.
v1::Trajectory HandPolynomial() {
  return MakeTrajectory(3,
                        {{2.0, {{1, 2, 3, 4, 5, 6}, {0, 0, 0, -1, 0, 0}, {0.5, 0, 0, 0, 0, 0}}}});
}

TEST(PolynomialTrajectoryTest, MatchesHandComputedValuesAndDerivatives) {
  const PolynomialTrajectory trajectory = Build(HandPolynomial());
  EXPECT_EQ(trajectory.dimension(), 3);
  EXPECT_EQ(trajectory.piece_count(), 1u);
  EXPECT_DOUBLE_EQ(trajectory.duration_s(), 2.0);
  const TrajectoryState s = trajectory.StateAt(0.5);
  // By hand at t = 0.5: x = 1 + 1 + 0.75 + 0.5 + 0.3125 + 0.1875.
  EXPECT_DOUBLE_EQ(s.position_m.x(), 3.75);
  EXPECT_DOUBLE_EQ(s.velocity_mps.x(), 2 + 3 + 3 + 2.5 + 1.875);  // 2 + 6t + 12t² + 20t³ + 30t⁴
  EXPECT_DOUBLE_EQ(s.acceleration_mps2.x(), 6 + 12 + 15 + 15);    // 6 + 24t + 60t² + 120t³
  EXPECT_DOUBLE_EQ(s.jerk_mps3.x(), 24 + 60 + 90);                // 24 + 120t + 360t²
  EXPECT_DOUBLE_EQ(s.position_m.y(), -0.125);
  EXPECT_DOUBLE_EQ(s.velocity_mps.y(), -0.75);
  EXPECT_DOUBLE_EQ(s.acceleration_mps2.y(), -3.0);
  EXPECT_DOUBLE_EQ(s.jerk_mps3.y(), -6.0);
  EXPECT_DOUBLE_EQ(s.position_m.z(), 0.5);
  EXPECT_EQ(s.velocity_mps.z(), 0.0);
  EXPECT_FALSE(s.body_height_m.has_value());
  // Snap (4th) and crackle (5th) derivatives, and zero beyond.
  EXPECT_DOUBLE_EQ(trajectory.Evaluate(0.5, 4)[0], 120 + 720 * 0.5);
  EXPECT_DOUBLE_EQ(trajectory.Evaluate(0.5, 5)[0], 720.0);
  EXPECT_EQ(trajectory.Evaluate(0.5, 6)[0], 0.0);
}

TEST(PolynomialTrajectoryTest, GlobalTimeSelectsThePieceAndItsLocalTime) {
  // Piece 0 (1.5 s): x = t. Piece 1 (0.5 s): x = 10 + 2t. Piece 2 (1 s): x = −t².
  const PolynomialTrajectory trajectory =
      Build(MakeTrajectory(3, {{1.5, {{0, 1, 0, 0, 0, 0}, {}, {}}},
                               {0.5, {{10, 2, 0, 0, 0, 0}, {}, {}}},
                               {1.0, {{0, 0, -1, 0, 0, 0}, {}, {}}}}));
  EXPECT_DOUBLE_EQ(trajectory.piece_start_s(1), 1.5);
  EXPECT_DOUBLE_EQ(trajectory.piece_start_s(2), 2.0);
  EXPECT_DOUBLE_EQ(trajectory.duration_s(), 3.0);
  EXPECT_DOUBLE_EQ(trajectory.PositionAt(1.0).x(), 1.0);
  EXPECT_DOUBLE_EQ(trajectory.PositionAt(1.75).x(), 10.5);
  EXPECT_DOUBLE_EQ(trajectory.VelocityAt(1.75).x(), 2.0);
  EXPECT_DOUBLE_EQ(trajectory.PositionAt(2.5).x(), -0.25);
  // A joint belongs to the later piece; the end evaluates the last piece at its end.
  EXPECT_DOUBLE_EQ(trajectory.PositionAt(1.5).x(), 10.0);
  EXPECT_DOUBLE_EQ(trajectory.PositionAt(3.0).x(), -1.0);
  EXPECT_DOUBLE_EQ(trajectory.VelocityAt(3.0).x(), -2.0);
}

TEST(PolynomialTrajectoryTest, HornerMatchesThePowerSeriesOnRandomPieces) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coefficient(-3, 3), duration(0.2, 2.0);
  std::vector<PieceSpec> specs;
  for (int i = 0; i < 5; ++i) {
    PieceSpec spec{duration(rng), {}};
    for (int a = 0; a < 4; ++a) {
      Coefficients c;
      for (double& value : c) value = coefficient(rng);
      spec.axes.push_back(c);
    }
    specs.push_back(spec);
  }
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(4, specs));
  double start = 0;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    for (double fraction : {0.1, 0.5, 0.9}) {
      const double local = fraction * specs[i].duration_s;
      for (int order = 0; order <= 5; ++order) {
        const Eigen::VectorXd value = trajectory.Evaluate(start + local, order);
        for (int a = 0; a < 4; ++a) {
          const double expected = PowerSeriesDerivative(specs[i].axes[a], local, order);
          EXPECT_NEAR(value[a], expected, 1e-9 * (1 + std::abs(expected)))
              << "piece " << i << " axis " << a << " order " << order;
        }
      }
    }
    start += specs[i].duration_s;
  }
}

TEST(PolynomialTrajectoryTest, DerivativesMatchFiniteDifferencesOfPosition) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> coefficient(-2, 2);
  std::vector<PieceSpec> specs;
  for (int i = 0; i < 3; ++i) {
    PieceSpec spec{1.0 + i * 0.5, {}};
    for (int a = 0; a < 3; ++a) {
      Coefficients c;
      for (double& value : c) value = coefficient(rng);
      spec.axes.push_back(c);
    }
    specs.push_back(spec);
  }
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(3, specs));
  std::uniform_real_distribution<double> fraction(0.05, 0.95);
  for (int sample = 0; sample < 30; ++sample) {
    const int piece = sample % 3;
    const double t = trajectory.piece_start_s(piece) + fraction(rng) * specs[piece].duration_s;
    const double h = 1e-3;  // Stays inside the piece (>= 0.05 s from its ends).
    auto p = [&](double tau) { return trajectory.PositionAt(tau); };
    const Eigen::Vector3d velocity = (p(t + h) - p(t - h)) / (2 * h);
    const Eigen::Vector3d acceleration = (p(t + h) - 2 * p(t) + p(t - h)) / (h * h);
    const Eigen::Vector3d jerk =
        (p(t + 2 * h) - 2 * p(t + h) + 2 * p(t - h) - p(t - 2 * h)) / (2 * h * h * h);
    const TrajectoryState state = trajectory.StateAt(t);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(state.velocity_mps[a], velocity[a], 1e-5 * (1 + std::abs(velocity[a]))) << t;
      EXPECT_NEAR(state.acceleration_mps2[a], acceleration[a],
                  1e-4 * (1 + std::abs(acceleration[a])))
          << t;
      EXPECT_NEAR(state.jerk_mps3[a], jerk[a], 1e-3 * (1 + std::abs(jerk[a]))) << t;
    }
  }
}

TEST(PolynomialTrajectoryTest, PiecesOfOneGlobalPolynomialAreContinuousAtTheirJoints) {
  const Coefficients x = {0.5, 1.0, -0.3, 0.2, -0.05, 0.004};
  const Coefficients y = {-1.0, 0.2, 0.4, -0.1, 0.01, 0.0};
  const Coefficients z = {0.3, 0.0, 0.05, 0.0, -0.002, 0.0001};
  const std::vector<double> durations = {0.7, 1.3, 0.4, 2.0};
  std::vector<PieceSpec> specs;
  double start = 0;
  for (double duration : durations) {
    specs.push_back(
        {duration,
         {ShiftPolynomial(x, start), ShiftPolynomial(y, start), ShiftPolynomial(z, start)}});
    start += duration;
  }
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(3, specs));
  for (std::size_t i = 1; i < trajectory.piece_count(); ++i) {
    const double joint = trajectory.piece_start_s(i);
    for (int order = 0; order <= 3; ++order) {
      // The end of piece i-1 equals the start of piece i, and both equal the global polynomial.
      const Eigen::VectorXd before =
          trajectory.EvaluatePiece(i - 1, trajectory.piece_duration_s(i - 1), order);
      const Eigen::VectorXd after = trajectory.EvaluatePiece(i, 0.0, order);
      EXPECT_NEAR((before - after).norm(), 0.0, 1e-10) << "joint " << i << " order " << order;
      EXPECT_NEAR(trajectory.Evaluate(joint, order)[0], PowerSeriesDerivative(x, joint, order),
                  1e-10);
      // And just either side of the joint, global time agrees with the global polynomial.
      for (double offset : {-1e-6, 1e-6}) {
        EXPECT_NEAR(trajectory.Evaluate(joint + offset, order)[1],
                    PowerSeriesDerivative(y, joint + offset, order), 1e-9);
      }
    }
  }
}

TEST(PolynomialTrajectoryTest, TimeBeforeTheStartClampsToTheStartState) {
  // Starts moving: x = 1 + 0.5t + 0.25t² (start velocity 0.5 m/s, acceleration 0.5 m/s²).
  const PolynomialTrajectory trajectory =
      Build(MakeTrajectory(3, {{2.0, {{1, 0.5, 0.25, 0, 0, 0}, {2, 0, 0, 0, 0, 0}, {}}}}));
  const TrajectoryState before = trajectory.StateAt(-3.0);
  const TrajectoryState start = trajectory.StateAt(0.0);
  EXPECT_EQ(before.time_s, -3.0);
  EXPECT_EQ(before.position_m, start.position_m);
  EXPECT_DOUBLE_EQ(before.position_m.x(), 1.0);
  EXPECT_DOUBLE_EQ(before.velocity_mps.x(), 0.5);
  EXPECT_DOUBLE_EQ(before.acceleration_mps2.x(), 0.5);
  EXPECT_DOUBLE_EQ(before.position_m.y(), 2.0);
}

TEST(PolynomialTrajectoryTest, TimePastTheEndHoldsTheFinalPositionAtRest) {
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(
      4,
      {{1.0,
        {{0, 1, 0, 0, 0, 0}, {0, 0, 1, 0, 0, 0}, {0.3, 0, 0, 0, 0, 0}, {0.5, 0.1, 0, 0, 0, 0}}}}));
  const TrajectoryState end = trajectory.StateAt(1.0);
  EXPECT_DOUBLE_EQ(end.velocity_mps.x(), 1.0);  // The end itself: the last piece's values.
  const TrajectoryState past = trajectory.StateAt(5.0);
  EXPECT_DOUBLE_EQ(past.position_m.x(), 1.0);
  EXPECT_DOUBLE_EQ(past.position_m.y(), 1.0);
  EXPECT_DOUBLE_EQ(past.position_m.z(), 0.3);
  EXPECT_EQ(past.velocity_mps, Eigen::Vector3d::Zero());
  EXPECT_EQ(past.acceleration_mps2, Eigen::Vector3d::Zero());
  EXPECT_EQ(past.jerk_mps3, Eigen::Vector3d::Zero());
  ASSERT_TRUE(past.body_height_m.has_value());
  EXPECT_DOUBLE_EQ(*past.body_height_m, 0.6);
  EXPECT_EQ(*past.body_height_rate_mps, 0.0);
  EXPECT_DOUBLE_EQ(*trajectory.StateAt(0.5).body_height_m, 0.55);
  EXPECT_DOUBLE_EQ(*trajectory.StateAt(0.5).body_height_rate_mps, 0.1);
}

TEST(PolynomialTrajectoryTest, BuildsFromAPlanResponse) {
  v1::PlanResponse response;
  *response.mutable_trajectory() = HandPolynomial();
  const auto trajectory = PolynomialTrajectory::FromPlanResponse(response);
  ASSERT_TRUE(trajectory.ok()) << trajectory.error().message;
  EXPECT_DOUBLE_EQ(trajectory->PositionAt(0.5).x(), 3.75);

  const auto missing = PolynomialTrajectory::FromPlanResponse(v1::PlanResponse());
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.error().message, HasSubstr("no trajectory"));
}

// Each malformed trajectory is refused with a message naming the field and the value.
struct MalformedCase {
  const char* name;
  void (*corrupt)(v1::Trajectory*);
  const char* expected_message;
};

class MalformedTrajectoryTest : public ::testing::TestWithParam<MalformedCase> {};

TEST_P(MalformedTrajectoryTest, IsRefusedWithAClearMessage) {
  v1::Trajectory trajectory =
      MakeTrajectory(3, {{1.0, {{0, 1, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}}},
                         {2.0, {{1, 1, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}}}});
  ASSERT_TRUE(PolynomialTrajectory::FromProto(trajectory).ok());
  GetParam().corrupt(&trajectory);
  const auto result = PolynomialTrajectory::FromProto(trajectory);
  ASSERT_FALSE(result.ok());
  EXPECT_THAT(result.error().message, HasSubstr(GetParam().expected_message));
  EXPECT_THAT(result.error().message, HasSubstr("invalid trajectory"));
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

INSTANTIATE_TEST_SUITE_P(
    Cases, MalformedTrajectoryTest,
    ::testing::Values(
        MalformedCase{"Dimension2", [](v1::Trajectory* t) { t->set_dimension(2); },
                      "dimension is 2; it must be 3 (x, y, z) or 4"},
        MalformedCase{"Dimension0", [](v1::Trajectory* t) { t->set_dimension(0); },
                      "dimension is 0"},
        MalformedCase{"NoPieces",
                      [](v1::Trajectory* t) {
                        t->clear_pieces();
                        t->set_duration_s(0);
                      },
                      "it has no pieces"},
        MalformedCase{"ZeroDuration",
                      [](v1::Trajectory* t) { t->mutable_pieces(1)->set_duration_s(0); },
                      "pieces[1].duration_s is 0 s; it must be > 0 and finite"},
        MalformedCase{"NegativeDuration",
                      [](v1::Trajectory* t) { t->mutable_pieces(0)->set_duration_s(-0.5); },
                      "pieces[0].duration_s is -0.5 s"},
        MalformedCase{"NaNDuration",
                      [](v1::Trajectory* t) { t->mutable_pieces(0)->set_duration_s(kNaN); },
                      "pieces[0].duration_s is nan s"},
        MalformedCase{"InfiniteDuration",
                      [](v1::Trajectory* t) { t->mutable_pieces(1)->set_duration_s(kInf); },
                      "pieces[1].duration_s is inf s"},
        MalformedCase{"MissingAxis",
                      [](v1::Trajectory* t) { t->mutable_pieces(1)->mutable_axes()->RemoveLast(); },
                      "pieces[1] has 2 axes; the trajectory's dimension is 3"},
        MalformedCase{"DimensionSaysFour", [](v1::Trajectory* t) { t->set_dimension(4); },
                      "pieces[0] has 3 axes; the trajectory's dimension is 4"},
        MalformedCase{"FiveCoefficients",
                      [](v1::Trajectory* t) {
                        t->mutable_pieces(1)->mutable_axes(2)->mutable_coefficients()->RemoveLast();
                      },
                      "pieces[1].axes[2] has 5 coefficients; a quintic needs exactly 6"},
        MalformedCase{
            "SevenCoefficients",
            [](v1::Trajectory* t) { t->mutable_pieces(0)->mutable_axes(0)->add_coefficients(1); },
            "pieces[0].axes[0] has 7 coefficients"},
        MalformedCase{"NaNCoefficient",
                      [](v1::Trajectory* t) {
                        t->mutable_pieces(0)->mutable_axes(1)->set_coefficients(3, kNaN);
                      },
                      "pieces[0].axes[1].coefficients[3] is nan; coefficients must be finite"},
        MalformedCase{"TotalDisagrees", [](v1::Trajectory* t) { t->set_duration_s(3.5); },
                      "duration_s is 3.5 s but the pieces last 3 s in total"}),
    [](const ::testing::TestParamInfo<MalformedCase>& info) { return info.param.name; });

}  // namespace
}  // namespace strata::client::testing
