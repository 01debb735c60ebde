#include "route_guides.hpp"

#include <algorithm>
#include <cmath>

namespace strata::fleet_internal {

std::vector<RouteGuide> ChooseGuides(std::span<const double> along_m,
                                     std::span<const double> wait_s, int max_stops, int max_points,
                                     double min_spacing_m) {
  const std::size_t n = along_m.size();
  std::vector<RouteGuide> chosen;
  if (n < 3 || max_points <= 0) return chosen;
  const double length_m = along_m[n - 1];
  const auto spaced = [&](std::size_t k) {
    if (along_m[k] < min_spacing_m || length_m - along_m[k] < min_spacing_m) return false;
    return std::none_of(chosen.begin(), chosen.end(), [&](const RouteGuide& g) {
      return std::abs(along_m[g.index] - along_m[k]) < min_spacing_m;
    });
  };
  // The longest waits on the way (the start's is the start's own, no stop).
  std::vector<std::size_t> waits;
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (wait_s[k] >= kGuideMinWaitS) waits.push_back(k);
  }
  std::sort(waits.begin(), waits.end(),
            [&](std::size_t a, std::size_t b) { return wait_s[a] > wait_s[b]; });
  for (const std::size_t k : waits) {
    if (static_cast<int>(chosen.size()) >= std::min(max_stops, max_points)) break;
    if (spaced(k)) chosen.push_back({k, true});
  }
  // Spread over the whole route: guides that end short of it leave the plan free on the rest.
  const int flowing = max_points - static_cast<int>(chosen.size());
  const double spacing_m = std::max(kGuideSpacingM, length_m / (flowing + 1));
  for (double at_m = spacing_m; at_m < length_m - spacing_m / 2; at_m += spacing_m) {
    if (static_cast<int>(chosen.size()) >= max_points) break;
    const auto k = static_cast<std::size_t>(std::lower_bound(along_m.begin(), along_m.end(), at_m) -
                                            along_m.begin());
    if (k < n && spaced(k)) chosen.push_back({k, false});
  }
  std::sort(chosen.begin(), chosen.end(),
            [](const RouteGuide& a, const RouteGuide& b) { return a.index < b.index; });
  return chosen;
}

}  // namespace strata::fleet_internal
