#pragma once
/// The independent check's config from the VerifierConfig a plan was verified with and the
/// keep-out zones it had to avoid: the one place the check meets the verifier's header, so
/// that the check itself (independent_check.cpp) never includes it.
#include <utility>
#include <vector>

#include "independent_check.hpp"
#include "strata/verification/trajectory_verifier.hpp"

namespace strata::bench {

inline IndependentCheckConfig CheckConfigFor(const VerifierConfig& verifier,
                                             std::vector<Prism> keep_out = {}) {
  return {.bounds = {.limit_tolerance = verifier.limit_tolerance,
                     .ground_tolerance_m = verifier.ground_tolerance_m,
                     .min_obstacle_distance_m = verifier.min_obstacle_distance_m},
          .keep_out = std::move(keep_out)};
}

}  // namespace strata::bench
