// The waits of a route in legs among other robots' motions (fleet/hold_schedule.hpp), on
// hand-made straight legs: a robot that cannot wait at its start, because another passes
// there, waits at the stop between its legs for a robot standing in its way to leave. Every
// schedule found is checked by sampling every millisecond.
#include "fleet/hold_schedule.hpp"

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

#include "test_util/reserved_motions.hpp"

namespace strata::fleet_internal {
namespace {

using test_util::Reserved;

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].
constexpr double kZ = 0.3;                                      // Reference height on a floor.

/// One piece from rest at `from` to rest at `to` in `duration_s` (a quintic smoothstep).
TrajectoryPiece Straight(const Eigen::Vector2d& from, const Eigen::Vector2d& to,
                         double duration_s) {
  TrajectoryPiece piece;
  piece.duration_s = duration_s;
  piece.coefficients = Eigen::MatrixXd::Zero(6, 3);
  const Eigen::Vector2d d = to - from;
  const double t = duration_s;
  piece.coefficients.row(0) << from.x(), from.y(), kZ;
  piece.coefficients.block<1, 2>(3, 0) = (10 / (t * t * t)) * d.transpose();
  piece.coefficients.block<1, 2>(4, 0) = (-15 / (t * t * t * t)) * d.transpose();
  piece.coefficients.block<1, 2>(5, 0) = (6 / (t * t * t * t * t)) * d.transpose();
  return piece;
}

Trajectory Of(std::vector<TrajectoryPiece> pieces) {
  Trajectory trajectory;
  trajectory.pieces = std::move(pieces);
  return trajectory;
}

/// The route: (0, 0) to a stop at (5, 0), then on to (10, 0), 5 s each. Robot "passer"
/// crosses the start 3.5 s after the departure; robot "stander" stands at (7.5, 0) for 15 s,
/// then leaves to (7.5, 10). Leaving at once meets the stander; waiting at the start meets the
/// passer: only a wait at the stop clears both.
struct Crossing {
  std::vector<Trajectory> legs = {Of({Straight({0, 0}, {5, 0}, 5)}),
                                  Of({Straight({5, 0}, {10, 0}, 5)})};
  std::vector<ReservedMotion> others = {
      Reserved("passer", AddSeconds(kDeparture, 0.5), Of({Straight({0, -6}, {0, 6}, 6)})),
      Reserved("stander", kDeparture,
               Of({RestAt(Eigen::Vector3d(7.5, 0, kZ), 15), Straight({7.5, 0}, {7.5, 10}, 10)}))};
  Traffic traffic;
  Crossing() {
    traffic.departure_ns = kDeparture;
    traffic.parked_until_ns = AddSeconds(kDeparture, 600);
    traffic.others = others;
  }
};

/// `legs` with `waits_s` before each, from the departure, parked until `traffic` says.
FleetMotion Scheduled(const std::vector<Trajectory>& legs, const std::vector<double>& waits_s,
                      const Traffic& traffic) {
  Trajectory route;
  for (std::size_t k = 0; k < legs.size(); ++k) {
    if (waits_s[k] > 0) route.pieces.push_back(RestAtStart(legs[k], waits_s[k]));
    route.pieces.insert(route.pieces.end(), legs[k].pieces.begin(), legs[k].pieces.end());
  }
  return traffic.MotionOf(route);
}

/// Whether `a` and `b`, sampled every millisecond, ever come within `limit_m` on one level.
bool MeetSampled(const FleetMotion& a, const FleetMotion& b, double limit_m) {
  for (std::int64_t t = std::max(a.start_ns, b.start_ns); t <= std::min(a.end_ns, b.end_ns);
       t += 1'000'000) {
    if ((a.ReferencePointAt(t) - b.ReferencePointAt(t)).head<2>().norm() < limit_m) return true;
  }
  return false;
}

double Limit(const Traffic& traffic) {
  return 2 * traffic.body.radius_m + traffic.rule.separation_m;
}

TEST(HoldSchedule, ARobotThatCannotWaitAtItsStartWaitsAtTheStopBetweenItsLegs) {
  const Crossing c;
  const auto scheduled = ScheduleHolds(c.legs, true, c.traffic, 60, 400);
  ASSERT_TRUE(std::holds_alternative<HoldSchedule>(scheduled));
  const HoldSchedule& holds = std::get<HoldSchedule>(scheduled);
  ASSERT_EQ(holds.waits_s.size(), 2u);
  // The passer reaches the start's limit about 2.8 s in; the stander leaves 15 s in.
  EXPECT_LT(holds.waits_s[0], 3.0);
  EXPECT_GT(holds.waits_s[0] + holds.waits_s[1], 15 - 7.5);
  EXPECT_GT(holds.waits_s[1], 0);
  EXPECT_LE(holds.waits_s[0] + holds.waits_s[1], 60);
  const FleetMotion motion = Scheduled(c.legs, holds.waits_s, c.traffic);
  for (const ReservedMotion& other : c.others) {
    EXPECT_FALSE(MeetSampled(motion, other.motion, Limit(c.traffic))) << other.robot_id;
  }
}

TEST(HoldSchedule, OneLegWithoutTheStopFindsNoWaitAndNamesTheStander) {
  const Crossing c;
  const std::vector<Trajectory> one_leg = {Of({c.legs[0].pieces[0], c.legs[1].pieces[0]})};
  const auto scheduled = ScheduleHolds(one_leg, true, c.traffic, 60, 400);
  ASSERT_TRUE(std::holds_alternative<HoldFailure>(scheduled));
  const HoldFailure& failure = std::get<HoldFailure>(scheduled);
  EXPECT_EQ(failure.leg, 0u);
  ASSERT_TRUE(failure.conflict);
  // The departure that got furthest met the stander; waiting longer met the passer first.
  EXPECT_EQ(c.others[failure.conflict->other].robot_id, "stander");
}

TEST(HoldSchedule, TheWaitsTogetherStayWithinTheBudget) {
  const Crossing c;
  const auto scheduled = ScheduleHolds(c.legs, true, c.traffic, 5, 400);
  EXPECT_TRUE(std::holds_alternative<HoldFailure>(scheduled));
}

TEST(HoldSchedule, ARobotAlreadyMovingLeavesItsStartAtOnce) {
  Crossing c;
  // The passer crosses just ahead of the start 1.2 s in: only a wait at the start clears it.
  c.others[0] =
      Reserved("passer", AddSeconds(kDeparture, -1.8), Of({Straight({0.8, -6}, {0.8, 6}, 6)}));
  c.others.pop_back();
  c.traffic.others = c.others;
  EXPECT_TRUE(
      std::holds_alternative<HoldSchedule>(ScheduleHolds(c.legs, true, c.traffic, 60, 400)));
  EXPECT_TRUE(
      std::holds_alternative<HoldFailure>(ScheduleHolds(c.legs, false, c.traffic, 60, 400)));
}

TEST(HoldSchedule, TheDeparturesCheckedStayWithinTheirBudget) {
  const Crossing c;
  const auto scheduled = ScheduleHolds(c.legs, true, c.traffic, 60, 3);
  ASSERT_TRUE(std::holds_alternative<HoldFailure>(scheduled));
  EXPECT_EQ(std::get<HoldFailure>(scheduled).departures_checked, 3);
}

TEST(HoldSchedule, TheWaitLadderGrowsToTheBudget) {
  const std::vector<double> ladder = WaitLadder(5);
  EXPECT_EQ(ladder.front(), 0);
  EXPECT_EQ(ladder.back(), 5);
  for (std::size_t i = 1; i < ladder.size(); ++i) EXPECT_GT(ladder[i], ladder[i - 1]);
  EXPECT_EQ(WaitLadder(0), std::vector<double>{0});
}

TEST(HoldSchedule, TheWaitsBackFromAHoldShrinkFromJustBelowItToNone) {
  const std::vector<double> back = WaitLadderBackFrom(5);
  EXPECT_EQ(back.front(), 4.5);
  EXPECT_EQ(back.back(), 0);
  for (std::size_t i = 1; i < back.size(); ++i) EXPECT_LT(back[i], back[i - 1]);
  EXPECT_EQ(WaitLadderBackFrom(0), std::vector<double>{0});
}

// The leg from the stop on as a robot making way at its goal takes it (ParkedLegs): the wait
// before it is parked time, which the route's budget of 5 s does not bound, and the robot
// leaves as late as it may.
TEST(HoldSchedule, WaitsBeforeParkedLegsAreNotBoundByTheRouteBudgetAndLeaveLatestFirst) {
  const Crossing c;
  const auto scheduled = ScheduleHolds(c.legs, true, c.traffic, 5, 400, ParkedLegs{1, 60, 0});
  ASSERT_TRUE(std::holds_alternative<HoldSchedule>(scheduled));
  const HoldSchedule& holds = std::get<HoldSchedule>(scheduled);
  EXPECT_LE(holds.waits_s[0], 5);
  // Standing at the stop meets nobody: the robot holds there for nearly all of its 60 s.
  EXPECT_GT(holds.waits_s[1], 55);
  EXPECT_LT(holds.waits_s[1], 60);
  const FleetMotion motion = Scheduled(c.legs, holds.waits_s, c.traffic);
  for (const ReservedMotion& other : c.others) {
    EXPECT_FALSE(MeetSampled(motion, other.motion, Limit(c.traffic))) << other.robot_id;
  }
  // Parked waits have their own bound: 1 s at the stop does not outlast the stander.
  EXPECT_TRUE(std::holds_alternative<HoldFailure>(
      ScheduleHolds(c.legs, true, c.traffic, 5, 400, ParkedLegs{1, 1, 0})));
}

}  // namespace
}  // namespace strata::fleet_internal
