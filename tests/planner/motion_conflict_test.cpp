// The exact conflict check between two robots' motions, against dense sampling.
#include "strata/fleet/motion_conflict.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>

#include <gtest/gtest.h>

#include "test_util/trajectory_builders.hpp"

namespace strata {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kMillisecond = 1'000'000;
constexpr std::int64_t kEpoch = 1'795'000'000 * kSecond;  // A date in 2026.

FleetMotion Moving(std::int64_t start_ns, const Eigen::Vector3d& from,
                   const Eigen::Vector3d& velocity, double duration_s, double parked_s = 0) {
  FleetMotion motion;
  motion.start_ns = start_ns;
  motion.trajectory.pieces.push_back(test_util::LinePiece(from, velocity, duration_s));
  motion.end_ns = AddSeconds(motion.ArrivalNs(), parked_s);
  return motion;
}

// The test's own account of a conflict at one moment, from the trajectories' values.
struct Closeness {
  double horizontal_m;
  double vertical_overlap_m;  // > 0 when the two bodies' extents overlap.
};

Closeness At(const FleetMotion& a, const FleetMotion& b, std::int64_t time_ns) {
  const auto state = [&](const FleetMotion& m) {
    const double t = std::clamp(static_cast<double>(time_ns - m.start_ns) * 1e-9, 0.0,
                                m.trajectory.TotalDuration());
    return m.trajectory.Evaluate(t, 0);
  };
  const StateVector pa = state(a);
  const StateVector pb = state(b);
  const double bottom_a = pa(2) - a.body.reference_height_m;
  const double bottom_b = pb(2) - b.body.reference_height_m;
  const double top_a = bottom_a + (a.trajectory.dimension == 4 ? pa(3) : a.body.height_m);
  const double top_b = bottom_b + (b.trajectory.dimension == 4 ? pb(3) : b.body.height_m);
  return {std::hypot(pa(0) - pb(0), pa(1) - pb(1)), std::min(top_a - bottom_b, top_b - bottom_a)};
}

double Limit(const FleetMotion& a, const FleetMotion& b, const SeparationRule& rule) {
  return a.body.radius_m + b.body.radius_m + rule.separation_m;
}

/// The first conflict a 1 ms sampling sees over the time both motions exist.
std::optional<std::int64_t> SampledFirstConflict(const FleetMotion& a, const FleetMotion& b,
                                                 const SeparationRule& rule) {
  const std::int64_t from = std::max(a.start_ns, b.start_ns);
  const std::int64_t until = std::min(a.end_ns, b.end_ns);
  for (std::int64_t t = from; t <= until; t += kMillisecond) {
    const Closeness c = At(a, b, t);
    if (c.horizontal_m < Limit(a, b, rule) && c.vertical_overlap_m > 0) return t;
  }
  return std::nullopt;
}

/// Checks the promise of motion_conflict.hpp for one reported conflict: at its moment the
/// bodies are within the tolerances of conflicting, and the report describes that moment.
void ExpectWithinTolerance(const FleetMotion& a, const FleetMotion& b, const SeparationRule& rule,
                           const MotionConflict& conflict) {
  const Closeness c = At(a, b, conflict.time_ns);
  EXPECT_LT(c.horizontal_m, Limit(a, b, rule) + rule.distance_tolerance_m + 1e-9);
  EXPECT_GT(c.vertical_overlap_m, -rule.vertical_tolerance_m - 1e-9);
  EXPECT_NEAR(conflict.horizontal_distance_m, c.horizontal_m, 1e-9);
  EXPECT_DOUBLE_EQ(conflict.limit_m, Limit(a, b, rule));
}

/// A random motion of 1-3 quintic pieces, continuous, within a 4 m square, 3-D or with a commanded
/// body height, starting within two seconds of kEpoch and parked for up to two seconds.
FleetMotion RandomMotion(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> pieces(1, 3);
  FleetMotion motion;
  motion.trajectory.dimension = rng() % 2 == 0 ? 3 : 4;
  const int n = pieces(rng);
  for (int i = 0; i < n; ++i) {
    TrajectoryPiece piece;
    piece.duration_s = 0.5 + 1.5 * (unit(rng) + 1.0);
    piece.coefficients = Eigen::MatrixXd::Zero(6, motion.trajectory.dimension);
    for (int axis = 0; axis < motion.trajectory.dimension; ++axis) {
      // Positions within ±2 m, heights within ±0.6 m, body heights 0.3-0.9 m; the higher
      // orders scaled so that the piece stays near that box.
      const double scale = axis < 2 ? 2.0 : (axis == 2 ? 0.6 : 0.3);
      const double centre = axis == 3 ? 0.6 : 0.0;
      for (int k = 0; k < 6; ++k) {
        piece.coefficients(k, axis) =
            (k == 0 ? centre : 0.0) + scale * unit(rng) / std::pow(piece.duration_s, k);
      }
    }
    if (i > 0) {  // Continuous, as planned trajectories are: each piece starts where the
                  // last ended.
      const TrajectoryPiece& last = motion.trajectory.pieces.back();
      piece.coefficients.row(0) = motion.trajectory.EvaluatePiece(i - 1, last.duration_s, 0);
    }
    motion.trajectory.pieces.push_back(piece);
  }
  motion.body.radius_m = 0.2 + 0.2 * (unit(rng) + 1.0) / 2;
  motion.body.reference_height_m = 0.2;
  motion.body.height_m = 0.5;
  motion.start_ns = kEpoch + static_cast<std::int64_t>(1e9 * (unit(rng) + 1.0));
  motion.end_ns = AddSeconds(motion.ArrivalNs(), unit(rng) + 1.0);
  return motion;
}

TEST(MotionConflict, AgreesWithDenseSamplingOnRandomPairs) {
  std::mt19937_64 rng(40);
  const SeparationRule rule;
  int conflicts = 0;
  int clear = 0;
  for (int trial = 0; trial < 300; ++trial) {
    SCOPED_TRACE(trial);
    const FleetMotion a = RandomMotion(rng);
    const FleetMotion b = RandomMotion(rng);
    ASSERT_TRUE(a.Validate("a")) << a.Validate("a").error().message;
    ASSERT_TRUE(b.Validate("b")) << b.Validate("b").error().message;
    const std::optional<MotionConflict> exact = FirstConflict(a, b, rule);
    const std::optional<std::int64_t> sampled = SampledFirstConflict(a, b, rule);
    if (sampled) {  // No miss, and never later than sampling saw it.
      ASSERT_TRUE(exact) << "sampling found a conflict at "
                         << static_cast<double>(*sampled - kEpoch) * 1e-9 << " s";
      EXPECT_LE(exact->time_ns, *sampled + 1);
    }
    if (exact) ExpectWithinTolerance(a, b, rule, *exact);  // No false alarm.
    // The check is symmetric.
    EXPECT_EQ(FirstConflict(b, a, rule).has_value(), exact.has_value());
    (exact ? conflicts : clear) += 1;
  }
  // Both outcomes are exercised often.
  EXPECT_GT(conflicts, 40);
  EXPECT_GT(clear, 60);
}

// Two robots cross at right angles at 2 m/s each; the second is offset along its way so that
// the closest approach of the two reference points is `limit + margin` at t = 3.0004 s, a
// moment between two milliseconds.
struct Crossing {
  FleetMotion a, b;
  std::int64_t closest_ns;
};

Crossing CrossingWithMargin(const SeparationRule& rule, double margin_m) {
  const FleetBody body;
  const double limit = 2 * body.radius_m + rule.separation_m;
  const double closest_s = 3.0004;
  const double speed = 2.0;
  // a runs along +x through the origin at closest_s; b along +y, displaced so that the
  // relative position at closest_s is perpendicular to the relative velocity (1, -1)·2.
  const double d = limit + margin_m;
  const Eigen::Vector3d va(speed, 0, 0);
  const Eigen::Vector3d vb(0, speed, 0);
  // At closest_s: a at (0, 0), b at (d/√2, d/√2): b − a ⟂ va − vb.
  const Eigen::Vector3d a_then(0, 0, 0.3);
  const Eigen::Vector3d b_then(d / std::sqrt(2.0), d / std::sqrt(2.0), 0.3);
  Crossing c;
  c.a = Moving(kEpoch, a_then - closest_s * va, va, 6.0);
  c.b = Moving(kEpoch, b_then - closest_s * vb, vb, 6.0);
  c.closest_ns = kEpoch + static_cast<std::int64_t>(closest_s * 1e9);
  return c;
}

TEST(MotionConflict, GrazingNearMissesAreToldApartAtTheTolerance) {
  const SeparationRule rule;
  // Clearly apart, by twice the tolerance: no conflict.
  for (double margin : {2e-3, 1e-2, 0.5}) {
    const Crossing c = CrossingWithMargin(rule, margin);
    EXPECT_FALSE(FirstConflict(c.a, c.b, rule)) << "margin " << margin;
    EXPECT_FALSE(SampledFirstConflict(c.a, c.b, rule)) << "margin " << margin;
  }
  // Closer than the limit, by as little as 0.1 µm: a conflict before the closest approach.
  for (double margin : {-1e-2, -1e-4, -1e-7}) {
    const Crossing c = CrossingWithMargin(rule, margin);
    const std::optional<MotionConflict> conflict = FirstConflict(c.a, c.b, rule);
    ASSERT_TRUE(conflict) << "margin " << margin;
    EXPECT_LE(conflict->time_ns, c.closest_ns);
    ExpectWithinTolerance(c.a, c.b, rule, *conflict);
  }
  // At 1e-7 m the conflict lasts about 0.2 ms around 3.0004 s: 1 ms sampling misses it.
  const Crossing brief = CrossingWithMargin(rule, -1e-7);
  EXPECT_FALSE(SampledFirstConflict(brief.a, brief.b, rule));
  EXPECT_LT(At(brief.a, brief.b, brief.closest_ns).horizontal_m, Limit(brief.a, brief.b, rule));
  // Within the tolerance beyond the limit: either answer, but a report keeps the promise.
  const Crossing grazing = CrossingWithMargin(rule, 5e-4);
  if (const auto conflict = FirstConflict(grazing.a, grazing.b, rule)) {
    ExpectWithinTolerance(grazing.a, grazing.b, rule, *conflict);
  }
}

TEST(MotionConflict, ReportsTheFirstOfTwoMeetings) {
  // b stands at x = 2, then at x = 6; a passes both: the report is the meeting at x = 2.
  const SeparationRule rule;
  const FleetMotion a = Moving(kEpoch, {0, 0, 0.3}, {1, 0, 0}, 8.0);
  FleetMotion b = Moving(kEpoch, {2, 0.2, 0.3}, {0, 0, 0}, 4.0);
  b.trajectory.pieces.push_back(test_util::LinePiece({6, 0.2, 0.3}, {0, 0, 0}, 4.0));
  b.end_ns = b.ArrivalNs();
  const std::optional<MotionConflict> conflict = FirstConflict(a, b, rule);
  ASSERT_TRUE(conflict);
  // a's reference point comes within the limit of (2, 0.2) at x = 2 − √(0.7² − 0.2²).
  const double enter_s = 2.0 - std::sqrt(0.7 * 0.7 - 0.2 * 0.2);
  EXPECT_NEAR(static_cast<double>(conflict->time_ns - kEpoch) * 1e-9, enter_s, 2e-3);
  EXPECT_NEAR(conflict->point_b.x(), 2.0, 1e-12);
}

TEST(MotionConflict, ThePairKeepsTheLargerOfTheRulesAndEachMotionsSeparation) {
  // a drives along y = 0 past b, standing 1 m off its line: 0.3 + 0.3 m of radii plus the
  // rule's 0.1 m is clear, plus 0.5 m asked by either motion is not.
  const SeparationRule rule;
  FleetMotion a = Moving(kEpoch, {0, 0, 0.3}, {1, 0, 0}, 6.0);
  FleetMotion b = Moving(kEpoch, {3, 1, 0.3}, {0, 0, 0}, 6.0);
  EXPECT_FALSE(FirstConflict(a, b, rule));
  b.separation_m = 0.5;
  std::optional<MotionConflict> conflict = FirstConflict(a, b, rule);
  ASSERT_TRUE(conflict);
  EXPECT_DOUBLE_EQ(conflict->limit_m, 1.1);
  EXPECT_DOUBLE_EQ(PairSeparationM(rule, a, b), 0.5);
  b.separation_m = 0;
  a.separation_m = 0.5;
  conflict = FirstConflict(a, b, rule);
  ASSERT_TRUE(conflict);
  EXPECT_DOUBLE_EQ(conflict->limit_m, 1.1);
  // a passes x = 3 - sqrt(1.1^2 - 1^2) first within the limit.
  EXPECT_NEAR(SecondsBetween(kEpoch, conflict->time_ns), 3 - std::sqrt(1.1 * 1.1 - 1), 2e-3);
}

TEST(MotionConflict, BodiesAtDifferentHeightsPassOverEachOther) {
  const SeparationRule rule;
  // a drives along x on the ground (reference point 0.3 m up, body 0.5 m tall: 0 to 0.5 m);
  // b drives along y on a deck whose surface is `deck_m` up, crossing a's way at the same time.
  const auto b_on_deck = [](double deck_m) {
    return Moving(kEpoch, {0, -3, deck_m + 0.3}, {0, 1, 0}, 6.0);
  };
  const FleetMotion a = Moving(kEpoch, {-3, 0, 0.3}, {1, 0, 0}, 6.0);
  EXPECT_FALSE(FirstConflict(a, b_on_deck(3.0), rule));   // A floor above.
  EXPECT_FALSE(FirstConflict(a, b_on_deck(0.6), rule));   // Just above a's top.
  EXPECT_TRUE(FirstConflict(a, b_on_deck(0.45), rule));   // Bodies overlap by 5 cm.
  EXPECT_TRUE(FirstConflict(a, b_on_deck(-0.45), rule));  // b below, a's bottom in b's top.

  // An active-height robot crouches (axis 3, body height) under b's deck at 0.6 m only while
  // its body height is below 0.6 m.
  const auto biped = [](double body_height_m) {
    FleetMotion m = Moving(kEpoch, {-3, 0, 0.2}, {1, 0, 0}, 6.0);
    m.trajectory.dimension = 4;
    auto& c = m.trajectory.pieces[0].coefficients;
    c.conservativeResize(6, 4);
    c.col(3).setZero();
    c(0, 3) = body_height_m;
    m.body.reference_height_m = 0.2;
    return m;
  };
  EXPECT_FALSE(FirstConflict(biped(0.55), b_on_deck(0.6), rule));
  EXPECT_TRUE(FirstConflict(biped(0.7), b_on_deck(0.6), rule));
}

TEST(MotionConflict, AParkedRobotHoldsItsPlaceUntilItsEnd) {
  const SeparationRule rule;
  // a arrives at (5, 0) after 5 s and stays parked there for 10 s more.
  const FleetMotion a = Moving(kEpoch, {0, 0, 0.3}, {1, 0, 0}, 5.0, 10.0);
  // b drives past (5, 0) along y, reaching it at `pass_s`.
  const auto b_passing_at = [](double pass_s) {
    return Moving(kEpoch, {5, -pass_s, 0.3}, {0, 1, 0}, 2 * pass_s);
  };
  EXPECT_TRUE(FirstConflict(a, b_passing_at(12.0), rule));   // a still parked.
  EXPECT_FALSE(FirstConflict(a, b_passing_at(16.0), rule));  // a's motion is over by then.
  // Motions that never exist at the same time never conflict.
  FleetMotion later = a;
  later.start_ns = a.end_ns + kSecond;
  later.end_ns = later.ArrivalNs();
  EXPECT_FALSE(FirstConflict(a, later, rule));
  // ...and a robot that starts where another stands conflicts at once.
  FleetMotion next = a;
  next.start_ns = a.end_ns - kSecond;
  next.end_ns = next.ArrivalNs();
  next.trajectory.pieces[0].coefficients.row(0) << 5, 0, 0.3;
  const std::optional<MotionConflict> conflict = FirstConflict(a, next, rule);
  ASSERT_TRUE(conflict);
  EXPECT_EQ(conflict->time_ns, next.start_ns);
}

TEST(MotionConflict, BadMotionsAndRulesAreBlamedByTheirField) {
  FleetMotion m = Moving(kEpoch, {0, 0, 0.3}, {1, 0, 0}, 5.0);
  EXPECT_TRUE(m.Validate("reservation"));
  FleetMotion bad = m;
  bad.body.radius_m = 0;
  EXPECT_EQ(bad.Validate("reservation").error().field, "reservation.body.radius_m");
  bad = m;
  bad.trajectory.pieces[0].coefficients(3, 1) = std::nan("");
  EXPECT_EQ(bad.Validate("reservation").error().field,
            "reservation.trajectory.pieces[0].coefficients");
  bad = m;
  bad.end_ns = m.ArrivalNs() - kMillisecond;
  EXPECT_EQ(bad.Validate("reservation").error().field, "reservation.end_ns");
  bad = m;
  bad.trajectory.pieces.clear();
  EXPECT_EQ(bad.Validate("reservation").error().field, "reservation.trajectory.pieces");
  for (const double separation : {-0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    bad = m;
    bad.separation_m = separation;
    EXPECT_EQ(bad.Validate("reservation").error().field, "reservation.separation_m");
  }
  SeparationRule rule;
  rule.separation_m = -0.1;
  const auto error = rule.Validate("fleet").error();
  EXPECT_EQ(error.field, "fleet.separation_m");
  EXPECT_EQ(error.message, "fleet.separation_m = -0.1 m must be at least 0 and finite");
}

}  // namespace
}  // namespace strata
