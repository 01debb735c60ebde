#include "maps/map_snapshot.hpp"

namespace strata::server {

double MapSnapshot::progress() const {
  // Loading takes the first tenth; the assessment's steps the rest, in the rough shares of
  // their time on large maps.
  constexpr double kStepShare[] = {0.05, 0.3, 0.2, 0.35};  // sorting ... fields.
  switch (stage) {
    case CreationStage::kQueued: return 0.0;
    case CreationStage::kLoading: return 0.05;
    case CreationStage::kAssessing: {
      // Summed the same way at the end of a step and at the start of the next, so the
      // progress never steps back by a rounding error.
      const auto step = static_cast<std::size_t>(assessment_step);
      double progress = 0.1;
      for (std::size_t i = 0; i < step; ++i) progress += kStepShare[i];
      return progress + kStepShare[step] * assessment_step_fraction;
    }
    case CreationStage::kDone: return 1.0;
  }
  return 0.0;
}

}  // namespace strata::server
