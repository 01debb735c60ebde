// Where a robot stops on its leg to let another robot pass (fleet/stop_places.hpp), on a
// hand-made leg along the x axis crossed by a robot driving along x = 8: the stop is the leg's
// latest point clear of that robot's whole way, and the search gives up when told to stop.
#include "fleet/stop_places.hpp"

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "test_util/reserved_motions.hpp"
#include "test_util/trajectory_builders.hpp"

namespace strata::fleet_internal {
namespace {

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].
constexpr double kZ = 0.3;                                      // Reference height on a floor.
constexpr double kCrossingX = 8;                                // Where the other robot drives.

/// The leg (0, 0) to (10, 0) in 10 s, met by robot "crosser" driving from (8, -10) to (8, 10)
/// over 13.2 s, at y = 0 when the leg is at x = 8 (6.6 s in).
struct Crossed {
  Trajectory leg =
      test_util::MinimumJerk(Eigen::Vector3d(0, 0, kZ), Eigen::Vector3d(10, 0, kZ), 10);
  std::vector<ReservedMotion> others;
  Traffic traffic;
  std::optional<TrafficConflict> met;
  Crossed() {
    others = {
        test_util::Reserved("crosser", kDeparture,
                            test_util::MinimumJerk(Eigen::Vector3d(kCrossingX, -10, kZ),
                                                   Eigen::Vector3d(kCrossingX, 10, kZ), 13.2))};
    traffic.departure_ns = kDeparture;
    traffic.parked_until_ns = AddSeconds(kDeparture, 600);
    traffic.others = others;
    met = FirstTrafficConflict(traffic.MotionOf(leg), traffic.others, traffic.rule);
  }
};

/// A `stands` that finds no ground beside the route, counting its calls.
struct NoGround {
  int calls = 0;
  std::optional<Eigen::Vector3d> operator()(const Eigen::Vector3d& /*p*/) {
    ++calls;
    return std::nullopt;
  }
};

TEST(StopBefore, IsTheLatestPointOfTheLegClearOfTheOtherRobotsWholeWay) {
  const Crossed c;
  ASSERT_TRUE(c.met);
  NoGround no_ground;
  const std::optional<AddedStop> stop =
      StopBefore(c.leg, kDeparture, *c.met, c.traffic, std::ref(no_ground), [] { return false; });
  ASSERT_TRUE(stop);
  // Clear of x = 8 by the limit and the stop's clearance (0.3 m), at most one 0.1 s step of the
  // leg (at most 0.19 m at its peak speed) before that.
  const double clear_m = 2 * c.traffic.body.radius_m + c.traffic.rule.separation_m + 0.3;
  EXPECT_LT(stop->position_m.x(), kCrossingX - clear_m);
  EXPECT_GT(stop->position_m.x(), kCrossingX - clear_m - 0.19);
  EXPECT_NEAR(stop->position_m.y(), 0, 1e-9);
  EXPECT_NEAR((c.leg.Position(stop->leg_time_s).head<3>() - stop->position_m).norm(), 0, 1e-9);
  EXPECT_LT(SecondsBetween(kDeparture, c.met->conflict.time_ns), 10.0);
}

TEST(StopBefore, StopsLookingWhenTheCallerSaysStop) {
  const Crossed c;
  ASSERT_TRUE(c.met);
  NoGround no_ground;
  int polls = 0;
  const std::optional<AddedStop> stop =
      StopBefore(c.leg, kDeparture, *c.met, c.traffic, std::ref(no_ground), [&] {
        ++polls;
        return true;
      });
  EXPECT_FALSE(stop);
  EXPECT_EQ(polls, 1);
  EXPECT_EQ(no_ground.calls, 0);
}

}  // namespace
}  // namespace strata::fleet_internal
