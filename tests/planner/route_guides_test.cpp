// The guides a plan through a space-time route is held to (fleet/route_guides.hpp): stops at
// the longest waits, flow-through points every kGuideSpacingM over the whole route, and on a
// route too long for the points allowed, spread further apart to its end.
#include "fleet/route_guides.hpp"

#include <algorithm>
#include <cstddef>
#include <vector>

#include <gtest/gtest.h>

namespace strata::fleet_internal {
namespace {

constexpr double kNodeStepM = 0.2;
constexpr double kMinSpacingM = 0.5;

// A straight route of `length_m` with a node every kNodeStepM: where each node lies.
std::vector<double> Along(double length_m) {
  std::vector<double> along;
  for (std::size_t k = 0; k * kNodeStepM <= length_m + 1e-9; ++k) along.push_back(k * kNodeStepM);
  return along;
}

std::vector<double> FlowPointsAlong(const std::vector<RouteGuide>& guides,
                                    const std::vector<double>& along) {
  std::vector<double> at;
  for (const RouteGuide& g : guides) {
    if (!g.stop) at.push_back(along[g.index]);
  }
  return at;
}

TEST(RouteGuides, AShortRouteGetsAFlowPointEverySpacing) {
  const std::vector<double> along = Along(40);
  const std::vector<double> waits(along.size(), 0.0);
  const std::vector<RouteGuide> guides = ChooseGuides(along, waits, 3, 61, kMinSpacingM);
  const std::vector<double> at = FlowPointsAlong(guides, along);
  ASSERT_EQ(at.size(), 9U);  // 4, 8, ..., 36 m.
  for (std::size_t i = 0; i < at.size(); ++i) EXPECT_NEAR(at[i], kGuideSpacingM * (i + 1), 1e-9);
}

TEST(RouteGuides, ARouteLongerThanThePointsAllowedIsGuidedToItsEnd) {
  const double length_m = 400;
  const std::vector<double> along = Along(length_m);
  const std::vector<double> waits(along.size(), 0.0);
  const int max_points = 61;
  const std::vector<RouteGuide> guides = ChooseGuides(along, waits, 3, max_points, kMinSpacingM);
  const std::vector<double> at = FlowPointsAlong(guides, along);
  ASSERT_EQ(static_cast<int>(at.size()), max_points);
  // Evenly spread over the whole route: no stretch longer than its share, the last one included.
  const double share_m = length_m / (max_points + 1);
  EXPECT_LE(at.front(), share_m + kNodeStepM);
  for (std::size_t i = 1; i < at.size(); ++i) EXPECT_LE(at[i] - at[i - 1], share_m + kNodeStepM);
  EXPECT_LE(length_m - at.back(), 1.5 * share_m);
}

TEST(RouteGuides, StopsGoAtTheLongestWaitsAwayFromTheEndsAndTheFlowPointsKeepClearOfThem) {
  const std::vector<double> along = Along(20);
  std::vector<double> waits(along.size(), 0.0);
  waits[1] = 9;     // 0.2 m from the start: too near it for a stop.
  waits[30] = 2;    // 6 m.
  waits[50] = 5;    // 10 m.
  waits[61] = 4;    // 12.2 m.
  waits[80] = 1;    // 16 m: the fourth longest, over the stops allowed.
  waits[90] = 0.2;  // Too short a wait for a stop.
  const std::vector<RouteGuide> guides = ChooseGuides(along, waits, 3, 61, kMinSpacingM);
  std::vector<std::size_t> stops;
  for (const RouteGuide& g : guides) {
    if (g.stop) stops.push_back(g.index);
  }
  EXPECT_EQ(stops, (std::vector<std::size_t>{30, 50, 61}));
  EXPECT_TRUE(
      std::is_sorted(guides.begin(), guides.end(),
                     [](const RouteGuide& a, const RouteGuide& b) { return a.index < b.index; }));
  for (std::size_t i = 1; i < guides.size(); ++i) {
    EXPECT_GE(along[guides[i].index] - along[guides[i - 1].index], kMinSpacingM - 1e-9);
  }
  // The flow point due at 12 m is within 0.5 m of the stop at 12.2 m: left out.
  const std::vector<double> at = FlowPointsAlong(guides, along);
  EXPECT_EQ(std::count_if(at.begin(), at.end(), [](double a) { return a > 11 && a < 13; }), 0);
  EXPECT_EQ(at.size(), 3U);  // 4, 8, 16 m.
}

}  // namespace
}  // namespace strata::fleet_internal
