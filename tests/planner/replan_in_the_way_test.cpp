// Which legs the plans of PlanReplanningOthers (fleet/replan_in_the_way.hpp) go through: the
// refused robot's tries going first share the cache of its refused try (the same robot, map
// and options: its first plan, without the others, comes out the same every time), and each
// robot replanned behind it, with another start and perhaps another profile, plans with its
// own. The planner is a stand-in that records what it is given.
#include "fleet/replan_in_the_way.hpp"

#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace strata::fleet_internal {
namespace {

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].

/// A robot under way from the departure: straight along y = `y` for 20 s.
ReservedMotion UnderWay(const std::string& robot, double y) {
  TrajectoryPiece piece;
  piece.duration_s = 20;
  piece.coefficients = Eigen::MatrixXd::Zero(6, 3);
  piece.coefficients.row(0) << 0, y, 0.3;
  piece.coefficients(1, 0) = 0.5;  // 0.5 m/s along x.
  ReservedMotion other;
  other.robot_id = robot;
  other.motion.start_ns = kDeparture;
  other.motion.trajectory.pieces = {piece};
  other.motion.end_ns = AddSeconds(other.motion.ArrivalNs(), 600);
  return other;
}

Error RefusedFor(const std::string& robot) {
  Error refusal{ErrorCode::kReservationConflict, "the trajectory meets robot " + robot};
  refusal.details["robot_id"] = robot;
  return refusal;
}

struct Call {
  bool going_first = false;  // The refused robot (nobody replannable in its request).
  LegCache* legs = nullptr;
};

struct ReplanningOthers : ::testing::Test {
  std::vector<ReservedMotion> others = {UnderWay("a", 0), UnderWay("b", 5)};
  std::vector<ReplannableRobot> replannable = {{0, RobotProfile{}}, {1, RobotProfile{}}};
  FleetPlanRequest request;
  std::vector<Call> calls;

  void SetUp() override {
    request.departure_ns = kDeparture;
    request.parked_until_ns = AddSeconds(kDeparture, 3600);
    request.others = others;
    request.replannable = replannable;
    request.fleet.replan.max_robots = 2;
  }

  /// Records each call; going first it is refused the first time for
  /// `going_first_refused_for` (when not empty) and planned otherwise; a robot replanned behind it
  /// is refused (enough to see the legs it was given).
  CommitOrderPlanner Recording(const std::string& going_first_refused_for) {
    return [this, going_first_refused_for](const FleetPlanRequest& r,
                                           LegCache* legs) -> Expected<FleetPlanResult> {
      const bool going_first = r.replannable.empty() && r.departure_ns == kDeparture;
      calls.push_back({going_first, legs});
      if (going_first && !going_first_refused_for.empty() && calls.size() == 1) {
        return RefusedFor(going_first_refused_for);
      }
      if (going_first) return FleetPlanResult{};
      return Error{ErrorCode::kReservationConflict, "no way behind the robot that goes first"};
    };
  }
};

TEST_F(ReplanningOthers, TheTryGoingFirstSharesTheRefusedTrysLegsAndTheReplannedRobotPlansAlone) {
  LegCache refused_try;
  const auto planned = PlanReplanningOthers(request, RefusedFor("a"), &refused_try, Recording(""));
  ASSERT_EQ(calls.size(), 2U) << "going first, then robot a behind it";
  EXPECT_TRUE(calls[0].going_first);
  EXPECT_EQ(calls[0].legs, &refused_try);
  EXPECT_FALSE(calls[1].going_first);
  EXPECT_EQ(calls[1].legs, nullptr);
  EXPECT_FALSE(planned) << "robot a found no way behind it: the first refusal stands";
}

TEST_F(ReplanningOthers, EveryTryGoingFirstSharesTheSameLegs) {
  LegCache refused_try;
  const auto planned = PlanReplanningOthers(request, RefusedFor("a"), &refused_try, Recording("b"));
  ASSERT_EQ(calls.size(), 3U) << "going first twice (refused for b), then a behind it";
  EXPECT_TRUE(calls[0].going_first && calls[1].going_first);
  EXPECT_EQ(calls[0].legs, &refused_try);
  EXPECT_EQ(calls[1].legs, &refused_try);
  EXPECT_FALSE(calls[2].going_first);
  EXPECT_EQ(calls[2].legs, nullptr);
  EXPECT_FALSE(planned) << "robot a found no way behind it: the first refusal stands";
}

}  // namespace
}  // namespace strata::fleet_internal
