#include "strata/planning/time_scaling.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "strata/planning/minco.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata {
namespace {

// A random minimum-jerk trajectory through `pieces` pieces, at rest at both ends unless
// `moving_ends`.
struct Random {
  Trajectory trajectory;
  Eigen::MatrixXd head, tail;
};
Random RandomTrajectory(std::mt19937* rng, int pieces, bool moving_ends) {
  std::uniform_real_distribution<double> coordinate(-5, 5), duration(0.5, 2.0), rate(-0.5, 0.5);
  Random r;
  r.head = Eigen::MatrixXd::Zero(3, 3);
  r.tail = Eigen::MatrixXd::Zero(3, 3);
  for (int axis = 0; axis < 3; ++axis) {
    r.head(axis, 0) = coordinate(*rng);
    r.tail(axis, 0) = coordinate(*rng);
    if (moving_ends) {
      r.head(axis, 1) = rate(*rng), r.head(axis, 2) = rate(*rng);
      r.tail(axis, 1) = rate(*rng), r.tail(axis, 2) = rate(*rng);
    }
  }
  Eigen::MatrixXd joints(3, pieces - 1);
  for (int k = 0; k < pieces - 1; ++k) {
    for (int axis = 0; axis < 3; ++axis) joints(axis, k) = coordinate(*rng);
  }
  Eigen::VectorXd durations(pieces);
  for (int k = 0; k < pieces; ++k) durations(k) = duration(*rng);
  Minco3 minco;
  minco.SetConditions(r.head, r.tail, pieces);
  minco.SetParameters(joints, durations);
  r.trajectory = Trajectory::FromMinco(minco);
  return r;
}

TEST(TimeScaling, StretchingFromRestIsTheSamePathSlowerExactly) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Random r = RandomTrajectory(&rng, 2 + trial % 7, false);
    const double k = 1.0 + 0.05 * (trial + 1);
    const Trajectory stretched = StretchTime(r.trajectory, k, r.head, r.tail);
    ASSERT_EQ(stretched.pieces.size(), r.trajectory.pieces.size());
    EXPECT_NEAR(stretched.TotalDuration(), k * r.trajectory.TotalDuration(), 1e-9);
    for (int s = 0; s <= 100; ++s) {
      const double t = r.trajectory.TotalDuration() * s / 100;
      const double scale = 1e-7 * (1 + r.trajectory.Position(t).norm());
      EXPECT_TRUE(stretched.Position(k * t).isApprox(r.trajectory.Position(t), scale))
          << trial << " t " << t;
      EXPECT_LT((stretched.Velocity(k * t) - r.trajectory.Velocity(t) / k).norm(), 1e-7);
      EXPECT_LT((stretched.Acceleration(k * t) - r.trajectory.Acceleration(t) / (k * k)).norm(),
                1e-7);
    }
  }
}

TEST(TimeScaling, TheRequiredScaleBringsEveryPeakWithinItsBound) {
  RobotProfile profile = BuiltinProfile("differential").value();
  std::mt19937 rng(9);
  int stretched_some = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Random r = RandomTrajectory(&rng, 3 + trial % 5, false);
    const DynamicPeaks before = SampleDynamicPeaks(r.trajectory, 0.005);
    const double k = RequiredTimeScale(before, profile, 0.99);
    ASSERT_GE(k, 1.0);
    stretched_some += k > 1;
    const Trajectory stretched = StretchTime(r.trajectory, k, r.head, r.tail);
    // Sampled at the same points of the path as before (every k · 5 ms).
    const DynamicPeaks after = SampleDynamicPeaks(stretched, k * 0.005);
    EXPECT_LE(after.speed_horizontal_mps, 0.99 * profile.max_speed_horizontal_mps + 1e-7);
    EXPECT_LE(after.speed_vertical_mps, 0.99 * profile.max_speed_vertical_mps + 1e-7);
    EXPECT_LE(after.accel_horizontal_mps2, 0.99 * profile.max_accel_horizontal_mps2 + 1e-7);
    EXPECT_LE(after.accel_vertical_mps2, 0.99 * profile.max_accel_vertical_mps2 + 1e-7);
    // The smallest such k: one bound sits exactly at its target.
    if (k > 1) {
      const double closest =
          std::max({after.speed_horizontal_mps / (0.99 * profile.max_speed_horizontal_mps),
                    after.speed_vertical_mps / (0.99 * profile.max_speed_vertical_mps),
                    after.accel_horizontal_mps2 / (0.99 * profile.max_accel_horizontal_mps2),
                    after.accel_vertical_mps2 / (0.99 * profile.max_accel_vertical_mps2)});
      EXPECT_NEAR(closest, 1.0, 1e-6) << trial;
    }
  }
  EXPECT_GT(stretched_some, 10);  // Random trajectories are mostly too fast for the robot.
}

TEST(TimeScaling, AMovingStartAndGoalKeepTheirStates) {
  std::mt19937 rng(17);
  const Random r = RandomTrajectory(&rng, 5, true);
  const Trajectory stretched = StretchTime(r.trajectory, 1.3, r.head, r.tail);
  const double end = stretched.TotalDuration();
  for (int order = 0; order < 3; ++order) {
    EXPECT_LT((stretched.Evaluate(0, order) - r.head.col(order)).norm(), 1e-9) << order;
    EXPECT_LT((stretched.Evaluate(end, order) - r.tail.col(order)).norm(), 1e-9) << order;
  }
  // The joints stay where they were.
  for (std::size_t i = 1; i < stretched.pieces.size(); ++i) {
    EXPECT_LT((stretched.pieces[i].coefficients.row(0) - r.trajectory.pieces[i].coefficients.row(0))
                  .norm(),
              1e-12);
  }
}

}  // namespace
}  // namespace strata
