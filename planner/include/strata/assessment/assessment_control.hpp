#pragma once
/// Following and stopping a terrain assessment: its stages, and the caller's callbacks.

#include <functional>

namespace strata {

/// The stages of an assessment, in order, as progress reports name them.
enum class AssessmentStage {
  kSorting,       ///< Grouping the points by grid column.
  kGroundFilter,  ///< Valid Ground Filter (fraction: rows of columns done).
  kSurfaces,      ///< Column surfaces and plane fits (fraction: columns done).
  kFields,        ///< d and S' (fraction: tiles done).
};

/// Stable lower_snake_case name of a stage, e.g. "ground_filter".
const char* AssessmentStageName(AssessmentStage stage);

/// How a caller follows and stops an assessment. Both callables may be empty. They are called
/// from the assessing threads, never two at a time, a few hundred times per assessment at most.
struct AssessmentControl {
  /// Receives the stage and the fraction of it done, in [0, 1].
  std::function<void(AssessmentStage stage, double fraction)> on_progress;
  /// Returning true stops the assessment within one unit of work per thread: kCancelled.
  std::function<bool()> should_stop;
};

}  // namespace strata
