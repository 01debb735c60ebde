// A robot's motion continued by a new plan: the committed one is kept until the new one
// departs, and nothing of it that is past.
#include "strata/fleet/fleet_motion.hpp"

#include <cstdint>

#include <gtest/gtest.h>

#include "test_util/trajectory_builders.hpp"

namespace strata {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kEpoch = 1'795'000'000 * kSecond;  // A date in 2026.

// East along y = 0 from x = 0 at 1 m/s, in pieces of 1 s, from kEpoch; parked until +60 s.
FleetMotion EastInPieces(int pieces) {
  FleetMotion motion;
  motion.start_ns = kEpoch;
  for (int i = 0; i < pieces; ++i) {
    motion.trajectory.pieces.push_back(test_util::LinePiece({double(i), 0, 0.3}, {1, 0, 0}, 1));
  }
  motion.end_ns = kEpoch + 60 * kSecond;
  return motion;
}

// North along x = `x` from y = 0 at 1 m/s for 5 s from `start_ns`; parked until +90 s.
FleetMotion NorthFrom(double x, std::int64_t start_ns) {
  FleetMotion motion;
  motion.start_ns = start_ns;
  motion.trajectory.pieces.push_back(test_util::LinePiece({x, 0, 0.3}, {0, 1, 0}, 5));
  motion.end_ns = kEpoch + 90 * kSecond;
  return motion;
}

TEST(ContinuedByTest, KeepsTheCommittedMotionFromNowUntilTheNewOneDeparts) {
  const FleetMotion current = EastInPieces(10);
  const std::int64_t now = kEpoch + 2'500'000'000;  // Half way through the third piece.
  const std::int64_t departure = kEpoch + 6'250'000'000;
  const FleetMotion next = NorthFrom(6.25, departure);
  const FleetMotion joined = ContinuedBy(current, next, now);
  ASSERT_TRUE(joined.Validate("joined"));

  // The pieces that ended by now are gone; the third starts it, the seventh is cut at 0.25 s.
  EXPECT_EQ(joined.start_ns, kEpoch + 2 * kSecond);
  ASSERT_EQ(joined.trajectory.pieces.size(), 5u + 1u);
  EXPECT_NEAR(joined.trajectory.pieces[4].duration_s, 0.25, 1e-12);
  EXPECT_EQ(joined.end_ns, next.end_ns);
  for (std::int64_t t = now; t < departure; t += 100'000'000) {
    EXPECT_TRUE(joined.ReferencePointAt(t).isApprox(current.ReferencePointAt(t), 1e-9))
        << "at " << SecondsBetween(kEpoch, t) << " s";
  }
  for (std::int64_t t = departure; t <= next.end_ns; t += 100'000'000) {
    EXPECT_TRUE(joined.ReferencePointAt(t).isApprox(next.ReferencePointAt(t), 1e-9))
        << "at " << SecondsBetween(kEpoch, t) << " s";
  }
}

TEST(ContinuedByTest, ARobotThatArrivesBeforeItsNewDepartureIsParkedAtItsGoalUntilThen) {
  const FleetMotion current = EastInPieces(3);  // At (3, 0) from +3 s.
  const std::int64_t departure = kEpoch + 20 * kSecond;
  const FleetMotion joined = ContinuedBy(current, NorthFrom(3, departure), kEpoch + kSecond);
  ASSERT_TRUE(joined.Validate("joined"));
  for (const double s : {3.0, 10.0, 19.9}) {
    EXPECT_TRUE(
        joined.ReferencePointAt(AddSeconds(kEpoch, s)).isApprox(Eigen::Vector3d(3, 0, 0.3), 1e-12))
        << "at " << s << " s";
  }
  EXPECT_TRUE(joined.ReferencePointAt(AddSeconds(kEpoch, 22)).isApprox(Eigen::Vector3d(3, 2, 0.3)));

  // Parked since before now: only the wait from now on is kept.
  const FleetMotion later = ContinuedBy(current, NorthFrom(3, departure), kEpoch + 8 * kSecond);
  ASSERT_EQ(later.trajectory.pieces.size(), 2u);
  EXPECT_EQ(later.start_ns, kEpoch + 8 * kSecond);
  EXPECT_TRUE(later.ReferencePointAt(kEpoch + 9 * kSecond).isApprox(Eigen::Vector3d(3, 0, 0.3)));
}

TEST(ContinuedByTest, ANewMotionDepartingByNowOrInAnotherDimensionReplacesTheOldOneWhole) {
  const FleetMotion current = EastInPieces(10);
  const std::int64_t now = kEpoch + 4 * kSecond;
  EXPECT_EQ(ContinuedBy(current, NorthFrom(4, now), now).start_ns, now);
  EXPECT_EQ(ContinuedBy(current, NorthFrom(4, now), now).trajectory.pieces.size(), 1u);
  // Before the committed motion starts: nothing of it is driven.
  FleetMotion early = NorthFrom(0, kEpoch - kSecond);
  EXPECT_EQ(ContinuedBy(current, early, kEpoch - 2 * kSecond).start_ns, early.start_ns);

  FleetMotion biped = NorthFrom(6, kEpoch + 6 * kSecond);
  biped.trajectory.dimension = 4;
  biped.trajectory.pieces[0].coefficients.conservativeResize(6, 4);
  biped.trajectory.pieces[0].coefficients.col(3).setZero();
  biped.trajectory.pieces[0].coefficients(0, 3) = 0.5;
  EXPECT_EQ(ContinuedBy(current, biped, now).trajectory.pieces.size(), 1u);
}

}  // namespace
}  // namespace strata
