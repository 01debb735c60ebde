// Which later departures a refused request is planned for (fleet/later_departures.hpp), with a
// stand-in for the planner at each departure that plans only from a given time on: the tries
// come in order within the robot's wait, the first plan found holds the robot at its start
// until it leaves, and a robot passing the start during that hold ends the tries.
#include "fleet/later_departures.hpp"

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util/reserved_motions.hpp"
#include "test_util/trajectory_builders.hpp"

namespace strata::fleet_internal {
namespace {

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].
constexpr double kZ = 0.3;                                      // Reference height on a floor.
constexpr double kTripS = 10;                                   // (0, 0) to (10, 0).

/// A request from rest at (0, 0) to (10, 0) that may replan others and wait `max_wait_s`.
FleetPlanRequest Request(double max_wait_s) {
  FleetPlanRequest request;
  request.plan.start.position_m = Eigen::Vector3d(0, 0, kZ);
  request.plan.goal.position_m = Eigen::Vector3d(10, 0, kZ);
  request.departure_ns = kDeparture;
  request.parked_until_ns = AddSeconds(kDeparture, 600);
  request.fleet.max_wait_s = max_wait_s;
  request.fleet.replan.max_robots = 1;
  return request;
}

Error Refused(const char* when) { return Error{ErrorCode::kReservationConflict, when}; }

/// Matches a list of times equal to `expected_s` within a nanosecond (the departures are
/// whole nanoseconds).
auto SecondsAre(std::vector<double> expected_s) {
  return ::testing::Pointwise(::testing::DoubleNear(1e-9), std::move(expected_s));
}

/// Stands in for planning at a departure: refuses every departure earlier than `plans_from_s`
/// after the request's, and plans the later ones straight to the goal. Records each try.
struct PlansFrom {
  double plans_from_s = 0;
  std::vector<double> tried_s;      ///< Each try's departure, after the request's [s].
  std::vector<double> max_waits_s;  ///< Each try's fleet.max_wait_s.

  Expected<FleetPlanResult> operator()(const FleetPlanRequest& later, LegCache* /*legs*/) {
    const double held_s = SecondsBetween(kDeparture, later.departure_ns);
    tried_s.push_back(held_s);
    max_waits_s.push_back(later.fleet.max_wait_s);
    if (held_s < plans_from_s) return Refused("refused later");
    FleetPlanResult planned;
    planned.plan.trajectory =
        test_util::MinimumJerk(later.plan.start.position_m, later.plan.goal.position_m, kTripS);
    planned.plan.stats.duration_s = kTripS;
    planned.arrival_s = kTripS;
    planned.motion.start_ns = later.departure_ns;
    planned.motion.trajectory = planned.plan.trajectory;
    planned.motion.end_ns = later.parked_until_ns;
    return planned;
  }
};

TEST(PlanLeavingLater, TriesFiveTenTwentyAndThirtySecondsLaterWithinTheWait) {
  PlansFrom never{1e9};
  const Expected<FleetPlanResult> refused =
      PlanLeavingLater(Request(60), Refused("refused at the departure"), nullptr, std::ref(never));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().message, "refused at the departure");
  EXPECT_THAT(never.tried_s, SecondsAre({5, 10, 20, 30}));
  // The hold counts against the wait.
  EXPECT_THAT(never.max_waits_s, SecondsAre({55, 50, 40, 30}));

  PlansFrom within_25{1e9};
  ASSERT_FALSE(PlanLeavingLater(Request(25), Refused("now"), nullptr, std::ref(within_25)));
  EXPECT_THAT(within_25.tried_s, SecondsAre({5, 10, 20}));
}

TEST(PlanLeavingLater, APlanFoundTwentySecondsLaterHoldsTheRobotAtItsStartUntilThen) {
  PlansFrom from_20{20};
  const Expected<FleetPlanResult> planned =
      PlanLeavingLater(Request(60), Refused("now"), nullptr, std::ref(from_20));
  ASSERT_TRUE(planned) << planned.error().message;
  EXPECT_THAT(from_20.tried_s, SecondsAre({5, 10, 20}));
  const FleetPlanResult& held = planned.value();
  ASSERT_EQ(held.holds.size(), 1U);
  EXPECT_EQ(held.holds.front().start_s, 0);
  EXPECT_DOUBLE_EQ(held.holds.front().duration_s, 20);
  EXPECT_DOUBLE_EQ(held.wait_s, 20);
  EXPECT_DOUBLE_EQ(held.arrival_s, 20 + kTripS);
  EXPECT_DOUBLE_EQ(held.plan.stats.duration_s, 20 + kTripS);
  // The motion begins at the request's departure, at rest at the start until 20 s.
  EXPECT_EQ(held.motion.start_ns, kDeparture);
  EXPECT_NEAR(held.motion.trajectory.TotalDuration(), 20 + kTripS, 1e-9);
  EXPECT_TRUE(held.motion.trajectory.Velocity(19.9).isZero(1e-12)) << "moves while it holds";
  EXPECT_NEAR(
      (held.motion.ReferencePointAt(AddSeconds(kDeparture, 19.9)) - Eigen::Vector3d(0, 0, kZ))
          .norm(),
      0, 1e-12);
  EXPECT_GT(held.motion.trajectory.Velocity(25).norm(), 0.1) << "not under way after the hold";
}

TEST(PlanLeavingLater, ARobotPassingTheStartDuringTheHoldEndsTheTries) {
  // A robot drives along x = 0 across the start, at y = 0 about 15 s after the departure.
  const std::vector<ReservedMotion> others = {test_util::Reserved(
      "crosser", AddSeconds(kDeparture, 10),
      test_util::MinimumJerk(Eigen::Vector3d(0, -10, kZ), Eigen::Vector3d(0, 10, kZ), 10))};
  FleetPlanRequest request = Request(60);
  request.others = others;

  PlansFrom from_20{20};
  const Expected<FleetPlanResult> refused =
      PlanLeavingLater(request, Refused("now"), nullptr, std::ref(from_20));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().message, "now");
  // Held 20 s, the robot would meet the crosser: a longer hold (30 s) meets it too.
  EXPECT_THAT(from_20.tried_s, SecondsAre({5, 10, 20}));
}

}  // namespace
}  // namespace strata::fleet_internal
