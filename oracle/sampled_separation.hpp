#pragma once
/// The benchmark's own check that two robots' motions keep apart, written apart from the
/// planner's exact check (strata/fleet/motion_conflict.hpp) so that "0 conflicts" is a
/// finding: it samples both motions every millisecond, evaluating the polynomials itself from
/// the layout trajectory.hpp documents, with the conflict rule of docs/design.md §19.
///
/// To stay affordable over a fleet's minutes it first samples every 50 ms, and samples every
/// millisecond only around the coarse samples where the robots could be within reach:
/// horizontally within the limit plus what `max_relative_speed_mps` covers in 25 ms.
#include <cstdint>
#include <optional>

#include "strata/fleet/fleet_motion.hpp"

namespace strata::bench {

struct SampledSeparation {
  /// The first millisecond sample at which the bodies conflict, if any [ns, absolute].
  std::optional<std::int64_t> first_conflict_ns;
  double closest_horizontal_m = 0;  ///< Over the samples where the extents overlap [m].
  long samples = 0;                 ///< Samples taken (coarse and fine).
};

/// Samples `a` and `b` over the time both exist. `limit_m`: the sum of the radii and the
/// separation; `max_relative_speed_mps`: a bound on how fast the two reference points approach
/// each other horizontally (the sum of their horizontal speed bounds, with the verifier's 1%).
SampledSeparation SampleSeparation(const FleetMotion& a, const FleetMotion& b, double limit_m,
                                   double max_relative_speed_mps);

}  // namespace strata::bench
