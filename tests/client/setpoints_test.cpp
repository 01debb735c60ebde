// MPC setpoints: yaw and yaw rate on a known circle, yaw rate against finite differences of
// yaw, held yaw at rest (start, end, past the end), body height, and argument checks.
#include "strata/client/setpoints.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/v1/planner_service.pb.h"
#include "trajectory_builders.hpp"

namespace strata::client::testing {
namespace {

using ::testing::HasSubstr;
constexpr double kPi = std::numbers::pi;

PolynomialTrajectory Build(const v1::Trajectory& proto) {
  auto result = PolynomialTrajectory::FromProto(proto);
  EXPECT_TRUE(result.ok()) << result.error().message;
  return std::move(result).value();
}

double AngleDifference(double a, double b) { return std::remainder(a - b, 2 * kPi); }

// A counter-clockwise circle of radius R about the origin at angular rate w, from angle 0,
// as quintic Hermite pieces of `piece_s` matching position, velocity and acceleration at
// every joint (interpolation error ~1e-9 m here). z = 0.2.
v1::Trajectory Circle(double radius_m, double rate_radps, double duration_s, double piece_s) {
  std::vector<PieceSpec> specs;
  const int pieces = static_cast<int>(std::lround(duration_s / piece_s));
  for (int i = 0; i < pieces; ++i) {
    const double t0 = i * piece_s, t1 = t0 + piece_s;
    auto axis = [&](auto f) {  // f(t, order) of the circle's axis.
      return QuinticHermite(f(t0, 0), f(t0, 1), f(t0, 2), f(t1, 0), f(t1, 1), f(t1, 2), piece_s);
    };
    auto x = [&](double t, int k) {
      const double w = rate_radps, r = radius_m;
      return k == 0   ? r * std::cos(w * t)
             : k == 1 ? -r * w * std::sin(w * t)
                      : -r * w * w * std::cos(w * t);
    };
    auto y = [&](double t, int k) {
      const double w = rate_radps, r = radius_m;
      return k == 0   ? r * std::sin(w * t)
             : k == 1 ? r * w * std::cos(w * t)
                      : -r * w * w * std::sin(w * t);
    };
    specs.push_back({piece_s, {axis(x), axis(y), Coefficients{0.2, 0, 0, 0, 0, 0}}});
  }
  return MakeTrajectory(3, specs);
}

TEST(SetpointsTest, YawAndYawRateOnAKnownCircle) {
  const double radius = 2.0, rate = 0.5;  // 1 m/s, turning left at 0.5 rad/s.
  const PolynomialTrajectory trajectory = Build(Circle(radius, rate, 4 * kPi, 0.1 * kPi));
  const auto setpoints = ComputeSetpoints(trajectory, 0.0, 0.05, 200);
  ASSERT_TRUE(setpoints.ok()) << setpoints.error().message;
  ASSERT_EQ(setpoints->size(), 200u);
  for (const MpcSetpoint& s : setpoints.value()) {
    const double angle = rate * s.time_s;
    EXPECT_NEAR(s.position_m.x(), radius * std::cos(angle), 1e-6);
    EXPECT_NEAR(s.position_m.y(), radius * std::sin(angle), 1e-6);
    EXPECT_NEAR(s.position_m.z(), 0.2, 1e-12);
    EXPECT_NEAR(s.speed_mps, radius * rate, 1e-6);
    // Tangent of a counter-clockwise circle: 90° ahead of the radius.
    EXPECT_NEAR(AngleDifference(s.yaw_rad, angle + kPi / 2), 0.0, 1e-6) << s.time_s;
    EXPECT_NEAR(s.yaw_rate_radps, rate, 1e-5) << s.time_s;
    EXPECT_FALSE(s.yaw_held);
    EXPECT_NEAR(s.acceleration_mps2.norm(), radius * rate * rate, 1e-5);  // Centripetal.
  }
}

TEST(SetpointsTest, UnwrappedYawIsContinuousOverMoreThanOneTurn) {
  const PolynomialTrajectory trajectory = Build(Circle(1.0, 1.0, 8.0, 0.25));
  const auto unwrapped = ComputeSetpoints(trajectory, 0.0, 0.1, 80);
  SetpointOptions wrapped_options;
  wrapped_options.unwrap_yaw = false;
  const auto wrapped = ComputeSetpoints(trajectory, 0.0, 0.1, 80, wrapped_options);
  ASSERT_TRUE(unwrapped.ok() && wrapped.ok());
  for (std::size_t k = 0; k < 80; ++k) {
    const double t = 0.1 * k;
    EXPECT_NEAR(unwrapped.value()[k].yaw_rad, kPi / 2 + t, 1e-5);  // Past 8 rad: no jumps.
    EXPECT_GT(wrapped.value()[k].yaw_rad, -kPi);
    EXPECT_LE(wrapped.value()[k].yaw_rad, kPi);
    EXPECT_NEAR(AngleDifference(wrapped.value()[k].yaw_rad, unwrapped.value()[k].yaw_rad), 0, 1e-9);
  }
}

TEST(SetpointsTest, YawRateMatchesFiniteDifferencesOfYaw) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coefficient(-1, 1);
  std::vector<PieceSpec> specs;
  for (int i = 0; i < 3; ++i) {
    PieceSpec spec{1.0, {}};
    for (int a = 0; a < 3; ++a) {
      Coefficients c;
      for (double& value : c) value = coefficient(rng);
      spec.axes.push_back(c);
    }
    spec.axes[0][1] = 2.0;  // Keep vx well away from zero: the yaw is always defined.
    specs.push_back(spec);
  }
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(3, specs));
  std::uniform_real_distribution<double> local(0.05, 0.95);
  for (int sample = 0; sample < 30; ++sample) {
    const double t = (sample % 3) + local(rng);
    const double h = 1e-5;
    const MpcSetpoint s = SetpointAt(trajectory, t);
    ASSERT_FALSE(s.yaw_held);
    const double numeric = AngleDifference(SetpointAt(trajectory, t + h).yaw_rad,
                                           SetpointAt(trajectory, t - h).yaw_rad) /
                           (2 * h);
    EXPECT_NEAR(s.yaw_rate_radps, numeric, 1e-5 * (1 + std::abs(numeric))) << t;
    const Eigen::Vector3d v = trajectory.VelocityAt(t);
    EXPECT_DOUBLE_EQ(s.speed_mps, std::hypot(v.x(), v.y()));
    EXPECT_DOUBLE_EQ(s.yaw_rad, std::atan2(v.y(), v.x()));
  }
}

// Rest to rest in 1 s: x' = 30t²(1−t)², y' = 2t(1−t)(1−2t). It leaves along +y (y' is first
// order at t = 0, x' second order) and arrives moving along −y.
v1::Trajectory RestToRest() {
  return MakeTrajectory(
      3, {{1.0, {{0, 0, 0, 10, -15, 6}, {0, 0, 1, -2, 1, 0}, {0.3, 0, 0, 0, 0, 0}}}});
}

TEST(SetpointsTest, AtRestTheYawIsHeldFromTheNearestMotion) {
  const PolynomialTrajectory trajectory = Build(RestToRest());
  // Start: at rest; the yaw is the first direction of motion (≈ +y), not 0.
  const MpcSetpoint start = SetpointAt(trajectory, 0.0);
  EXPECT_TRUE(start.yaw_held);
  EXPECT_EQ(start.speed_mps, 0.0);
  EXPECT_EQ(start.yaw_rate_radps, 0.0);
  EXPECT_NEAR(start.yaw_rad, kPi / 2, 0.02);
  // Before the start: the same.
  const MpcSetpoint before = SetpointAt(trajectory, -2.0);
  EXPECT_TRUE(before.yaw_held);
  EXPECT_DOUBLE_EQ(before.yaw_rad, start.yaw_rad);
  EXPECT_EQ(before.position_m, trajectory.PositionAt(0.0));
  // End and past it: the last direction of motion (≈ −y), zero speed, rate, acceleration.
  for (double t : {1.0, 1.5, 30.0}) {
    const MpcSetpoint s = SetpointAt(trajectory, t);
    EXPECT_TRUE(s.yaw_held) << t;
    EXPECT_NEAR(s.yaw_rad, -kPi / 2, 0.02) << t;
    EXPECT_EQ(s.yaw_rate_radps, 0.0);
    EXPECT_DOUBLE_EQ(s.position_m.x(), 1.0);
    EXPECT_NEAR(s.position_m.y(), 0.0, 1e-12);
  }
  EXPECT_EQ(SetpointAt(trajectory, 1.5).acceleration_mps2, Eigen::Vector3d::Zero());
  // The held yaw is the heading where the speed crosses the threshold: check it directly.
  SetpointOptions options;
  const MpcSetpoint held = SetpointAt(trajectory, 1.0, options);
  double lo = 0.5, hi = 1.0;  // Speed above the threshold at lo, below at hi.
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (SetpointAt(trajectory, mid).speed_mps >= options.min_speed_for_yaw_mps ? lo : hi) = mid;
  }
  EXPECT_NEAR(held.yaw_rad, SetpointAt(trajectory, lo).yaw_rad, 1e-6);
}

TEST(SetpointsTest, HorizonSamplesTheTrajectoryAtT0PlusKDt) {
  const PolynomialTrajectory trajectory = Build(RestToRest());
  const auto setpoints = ComputeSetpoints(trajectory, 0.25, 0.2, 6);
  ASSERT_TRUE(setpoints.ok());
  ASSERT_EQ(setpoints->size(), 6u);
  for (int k = 0; k < 6; ++k) {
    const MpcSetpoint& s = setpoints.value()[k];
    const double t = 0.25 + 0.2 * k;
    EXPECT_DOUBLE_EQ(s.time_s, t);
    EXPECT_EQ(s.position_m, trajectory.PositionAt(t));
    EXPECT_EQ(s.velocity_mps, trajectory.VelocityAt(t));
    EXPECT_EQ(s.acceleration_mps2, trajectory.AccelerationAt(t));
    EXPECT_FALSE(s.body_height_m.has_value());
  }
  EXPECT_TRUE(setpoints.value()[5].yaw_held);  // t = 1.25: past the end.
}

TEST(SetpointsTest, OnTheWallClockTheRobotHoldsItsStartUntilItsDeparture) {
  const PolynomialTrajectory trajectory = Build(RestToRest());
  v1::PlanResponse response;
  response.mutable_departure_time()->set_seconds(1'795'000'000);
  response.mutable_departure_time()->set_nanos(500'000'000);
  const auto departure = DepartureOf(response);
  ASSERT_TRUE(departure.has_value());
  EXPECT_EQ(departure->time_since_epoch(), std::chrono::milliseconds(1'795'000'000'500));
  EXPECT_FALSE(DepartureOf(v1::PlanResponse()).has_value());

  const auto setpoints = ComputeSetpointsAt(trajectory, *departure,
                                            *departure - std::chrono::milliseconds(500), 0.25, 4);
  ASSERT_TRUE(setpoints.ok());
  // Half a second before the departure, then a quarter: the robot waits at the start.
  EXPECT_DOUBLE_EQ(setpoints.value()[0].time_s, -0.5);
  EXPECT_EQ(setpoints.value()[0].position_m, trajectory.PositionAt(0));
  EXPECT_EQ(setpoints.value()[1].position_m, trajectory.PositionAt(0));
  EXPECT_DOUBLE_EQ(setpoints.value()[3].time_s, 0.25);
  EXPECT_EQ(setpoints.value()[3].position_m, trajectory.PositionAt(0.25));
  EXPECT_NE(setpoints.value()[3].position_m, trajectory.PositionAt(0));
}

TEST(SetpointsTest, DimensionFourCarriesTheBodyHeight) {
  const PolynomialTrajectory trajectory = Build(MakeTrajectory(
      4, {{2.0, {{0, 0.5, 0, 0, 0, 0}, {}, {0.3, 0, 0, 0, 0, 0}, {0.5, 0.05, 0, 0, 0, 0}}}}));
  const auto setpoints = ComputeSetpoints(trajectory, 0.0, 1.0, 4);
  ASSERT_TRUE(setpoints.ok());
  const double expected[] = {0.5, 0.55, 0.6, 0.6};  // Held at the end.
  for (int k = 0; k < 4; ++k) {
    ASSERT_TRUE(setpoints.value()[k].body_height_m.has_value());
    EXPECT_DOUBLE_EQ(*setpoints.value()[k].body_height_m, expected[k]);
  }
  EXPECT_DOUBLE_EQ(setpoints.value()[1].yaw_rad, 0.0);
  EXPECT_DOUBLE_EQ(setpoints.value()[1].speed_mps, 0.5);
}

TEST(SetpointsTest, ATrajectoryThatNeverMovesHasYawZeroHeld) {
  const PolynomialTrajectory trajectory =
      Build(MakeTrajectory(3, {{1.0, {{1, 0, 0, 0, 0, 0}, {2, 0, 0, 0, 0, 0}, {}}}}));
  const MpcSetpoint s = SetpointAt(trajectory, 0.5);
  EXPECT_TRUE(s.yaw_held);
  EXPECT_EQ(s.yaw_rad, 0.0);
  EXPECT_EQ(s.speed_mps, 0.0);
}

TEST(SetpointsTest, BadArgumentsAreRefusedByName) {
  const PolynomialTrajectory trajectory = Build(RestToRest());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(ComputeSetpoints(trajectory, 0, 0.0, 5).error().message,
              HasSubstr("dt_s is 0 s; it must be > 0 and finite"));
  EXPECT_THAT(ComputeSetpoints(trajectory, 0, -0.1, 5).error().message, HasSubstr("dt_s is -0.1"));
  EXPECT_THAT(ComputeSetpoints(trajectory, 0, 0.1, 0).error().message,
              HasSubstr("steps is 0; it must be in [1, 1000000]"));
  EXPECT_THAT(ComputeSetpoints(trajectory, nan, 0.1, 5).error().message,
              HasSubstr("t0_s is nan; it must be finite"));
  SetpointOptions options;
  options.min_speed_for_yaw_mps = 0;
  EXPECT_THAT(ComputeSetpoints(trajectory, 0, 0.1, 5, options).error().message,
              HasSubstr("min_speed_for_yaw_mps is 0 m/s"));
  options = {};
  options.yaw_search_step_s = -1;
  EXPECT_THAT(options.Validate()->message, HasSubstr("yaw_search_step_s is -1 s"));
  EXPECT_FALSE(SetpointOptions{}.Validate().has_value());
}

}  // namespace
}  // namespace strata::client::testing
