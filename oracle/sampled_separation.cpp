#include "sampled_separation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace strata::bench {
namespace {

constexpr std::int64_t kFineNs = 1'000'000;     // 1 ms
constexpr std::int64_t kCoarseNs = 50'000'000;  // 50 ms

struct Body {
  double x, y, bottom, top;
};

// The motion's body at absolute time t: its own Horner evaluation of the piece in effect,
// the trajectory's first point before its start and its last after its end.
Body At(const FleetMotion& m, std::int64_t t_ns) {
  double t = static_cast<double>(t_ns - m.start_ns) * 1e-9;
  std::size_t piece = 0;
  while (piece + 1 < m.trajectory.pieces.size() && t > m.trajectory.pieces[piece].duration_s) {
    t -= m.trajectory.pieces[piece].duration_s;
    ++piece;
  }
  const TrajectoryPiece& p = m.trajectory.pieces[piece];
  t = std::clamp(t, 0.0, p.duration_s);
  double value[4] = {0, 0, 0, 0};
  for (int axis = 0; axis < m.trajectory.dimension; ++axis) {
    for (int k = 5; k >= 0; --k) value[axis] = value[axis] * t + p.coefficients(k, axis);
  }
  const double bottom = value[2] - m.body.reference_height_m;
  const double height = m.trajectory.dimension == 4 ? value[3] : m.body.height_m;
  return {value[0], value[1], bottom, bottom + height};
}

}  // namespace

SampledSeparation SampleSeparation(const FleetMotion& a, const FleetMotion& b, double limit_m,
                                   double max_relative_speed_mps) {
  SampledSeparation result;
  result.closest_horizontal_m = std::numeric_limits<double>::infinity();
  const std::int64_t from = std::max(a.start_ns, b.start_ns);
  const std::int64_t until = std::min(a.end_ns, b.end_ns);
  // Within this of a coarse sample, the horizontal distance changes by at most `reach`.
  const double reach = max_relative_speed_mps * 1e-9 * static_cast<double>(kCoarseNs) / 2;
  const auto sample = [&](std::int64_t t) {
    ++result.samples;
    const Body pa = At(a, t);
    const Body pb = At(b, t);
    const double d = std::hypot(pa.x - pb.x, pa.y - pb.y);
    const bool overlap = pa.top > pb.bottom && pb.top > pa.bottom;
    if (overlap) result.closest_horizontal_m = std::min(result.closest_horizontal_m, d);
    return std::pair{d, overlap};
  };
  // Each coarse sample stands for the 50 ms around it; the last may lie past `until`, and is
  // then taken at `until`, still within 25 ms of every moment it stands for.
  for (std::int64_t coarse = from; coarse - kCoarseNs / 2 <= until; coarse += kCoarseNs) {
    // Only the horizontal distance rules a stretch out; the fine samples decide the rest.
    if (sample(std::min(coarse, until)).first >= limit_m + reach) continue;
    const std::int64_t lo = std::max(from, coarse - kCoarseNs / 2);
    const std::int64_t hi = std::min(until, coarse + kCoarseNs / 2);
    for (std::int64_t t = lo; t <= hi; t += kFineNs) {
      const auto [d, overlap] = sample(t);
      if (overlap && d < limit_m) {
        result.first_conflict_ns = t;
        return result;
      }
    }
  }
  return result;
}

}  // namespace strata::bench
