#pragma once
/// What terrain assessment derives from the whole cloud, shared with the local reassessment
/// of an edit (strata/assessment/map_edit.hpp), which must derive it the same way.

#include <chrono>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// Seconds between laps, for the assessment's per-stage timings.
class Stopwatch {
 public:
  double Lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// The ground filter's step tolerance on a cloud with this vertical quantum
/// (FilterValidGround's `step_tolerance_m`; 0 for a sensor's cloud).
double StepTolerance(double vertical_quantum_m);

/// The grid an assessment lays over a cloud with these bounds and vertical quantum (fails as
/// MakeGridGeometry).
Expected<GridGeometry> AssessmentGrid(const AssessmentSummary& summary, const GridConfig& grid);

}  // namespace strata::internal
