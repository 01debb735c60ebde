#pragma once
/// Building the column surfaces of some of the grid's columns (strata/assessment/surface_map.hpp):
/// all of them for an assessment, those around an edit for a local reassessment
/// (strata/assessment/map_edit.hpp).

#include <cstdint>
#include <vector>

#include "assessment/assessment_progress.hpp"
#include "assessment/column_cloud.hpp"
#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// How many columns away the plane fit of a surface reads points (field.plane_fit_radius_m
/// on a grid of `resolution_m`): a surface depends on the points of these columns and on
/// the valid flags of its own column only.
int PlaneFitReach(const FieldConfig& field, double resolution_m);

/// The surfaces of the columns of `window` (grid indices, x and y) from `sorted`, whose
/// window must hold every column within PlaneFitReach of them (inside the grid) with the
/// valid flags of the window's own columns set. `progress` (may be null) counts columns and
/// may stop the build: kCancelled.
Expected<ColumnSurfaces> BuildColumnSurfaces(const GridGeometry& geometry,
                                             const ColumnCloud& sorted, const CellBox& window,
                                             const FieldConfig& field, int num_threads,
                                             ProgressReporter* progress);

}  // namespace strata::internal
