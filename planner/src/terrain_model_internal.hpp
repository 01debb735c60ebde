#pragma once
/// What terrain assessment derives from the whole cloud, shared with the local reassessment
/// of an edit (strata/map_edit.hpp), which must derive it the same way.

#include "strata/grid.hpp"
#include "strata/status.hpp"
#include "strata/terrain_config.hpp"
#include "strata/terrain_model.hpp"

namespace strata::internal {

/// The ground filter's step tolerance on a cloud with this vertical quantum
/// (FilterValidGround's `step_tolerance_m`; 0 for a sensor's cloud).
double StepTolerance(double vertical_quantum_m);

/// The grid an assessment lays over a cloud with these bounds and vertical quantum (fails as
/// MakeGridGeometry).
Expected<GridGeometry> AssessmentGrid(const AssessmentSummary& summary, const GridConfig& grid);

}  // namespace strata::internal
