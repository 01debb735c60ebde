// The benchmark's own separation check (oracle/sampled_separation.hpp) on crossings whose
// closest approach is known in closed form.
#include "sampled_separation.hpp"

#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

namespace strata::bench {
namespace {

constexpr std::int64_t kEpoch = 1'795'000'000'000'000'000;

FleetMotion Line(const Eigen::Vector3d& from, const Eigen::Vector3d& velocity, double duration_s) {
  FleetMotion m;
  m.start_ns = kEpoch;
  TrajectoryPiece piece;
  piece.duration_s = duration_s;
  piece.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  piece.coefficients.row(0) = from.transpose();
  piece.coefficients.row(1) = velocity.transpose();
  m.trajectory.pieces.push_back(piece);
  m.end_ns = m.ArrivalNs();
  return m;
}

// Two robots at 1 m/s crossing at right angles; the closest approach of their reference
// points is `distance_m`, at 5.0123 s (between two coarse samples).
void Crossing(double distance_m, FleetMotion* a, FleetMotion* b) {
  const double t = 5.0123;
  const double side = distance_m / std::sqrt(2.0);
  *a = Line(Eigen::Vector3d(-t, 0, 0.3), {1, 0, 0}, 10);
  *b = Line(Eigen::Vector3d(side, side - t, 0.3), {0, 1, 0}, 10);
}

TEST(SampledSeparation, FindsACloseCrossingBetweenCoarseSamplesAndClearsAWideOne) {
  FleetMotion a, b;
  Crossing(0.69, &a, &b);
  const SampledSeparation close = SampleSeparation(a, b, 0.7, 2.02);
  ASSERT_TRUE(close.first_conflict_ns);
  // The distance² is 0.69² + 2·(t − 5.0123)²: below 0.7² from 5.0123 − √((0.49 − 0.4761) / 2).
  const double enter_s = 5.0123 - std::sqrt((0.49 - 0.4761) / 2);
  EXPECT_NEAR(static_cast<double>(*close.first_conflict_ns - kEpoch) * 1e-9, enter_s, 0.0011);
  Crossing(0.71, &a, &b);
  const SampledSeparation wide = SampleSeparation(a, b, 0.7, 2.02);
  EXPECT_FALSE(wide.first_conflict_ns);
  EXPECT_NEAR(wide.closest_horizontal_m, 0.71, 1e-3);
  // Far apart, only the coarse samples are taken: one per 50 ms over 10 s.
  a = Line(Eigen::Vector3d(0, 0, 0.3), {1, 0, 0}, 10);
  b = Line(Eigen::Vector3d(0, 5, 0.3), {1, 0, 0}, 10);
  EXPECT_EQ(SampleSeparation(a, b, 0.7, 2.02).samples, 201);
}

TEST(SampledSeparation, BodiesAtDifferentHeightsDoNotConflict) {
  FleetMotion a, b;
  Crossing(0.2, &a, &b);
  b.trajectory.pieces[0].coefficients(0, 2) += 2.0;  // b on a deck 2 m up.
  EXPECT_FALSE(SampleSeparation(a, b, 0.7, 2.02).first_conflict_ns);
}

}  // namespace
}  // namespace strata::bench
