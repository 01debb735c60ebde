#pragma once
/// Where a plan through a space-time route (space_time_search.hpp) is held to it: the stops
/// where the route waits longest, and points it flows through along the rest, so that the
/// optimised trajectory takes the way (and keeps the pace) the search chose.
#include <cstddef>
#include <span>
#include <vector>

namespace strata::fleet_internal {

/// A stop is made where the route waits at least this long [s].
inline constexpr double kGuideMinWaitS = 0.3;
/// Flow-through points this far apart along the route [m]. Between points 8 m apart the
/// shortened path took its own line, up to 1.9 m off the route, where the robots the search
/// had kept clear of passed (docs/design.md, "Fleets").
inline constexpr double kGuideSpacingM = 4.0;

/// A point of the route the plan passes: its index among the route's nodes, and whether the
/// robot stops there.
struct RouteGuide {
  std::size_t index = 0;
  bool stop = false;
};

/// The guides of a route whose nodes lie `along_m` from its start (ascending) and which waits
/// `wait_s` at each before leaving it: up to `max_stops` stops at the longest waits of at
/// least kGuideMinWaitS (not at the ends), then flow-through points every kGuideSpacingM over
/// the whole route, further apart only where `max_points` in all would not reach its end;
/// none nearer than `min_spacing_m` to another or to the ends. Ascending by index.
std::vector<RouteGuide> ChooseGuides(std::span<const double> along_m,
                                     std::span<const double> wait_s, int max_stops, int max_points,
                                     double min_spacing_m);

}  // namespace strata::fleet_internal
