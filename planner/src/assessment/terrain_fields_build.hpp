#pragma once
/// Computing the band-stored fields of an assessed map (strata/assessment/terrain_fields.hpp).

#include "assessment/assessment_progress.hpp"
#include "assessment/column_cloud.hpp"
#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_fields.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// How far, in columns, the stored fields of a column depend on other columns.
struct FieldReach {
  /// On the surfaces of the columns this far: the band's extent reads the 8 neighbours, S'
  /// reads S up to the diffusion kernel's reach, and S at a column reads ∇H's neighbours.
  int surfaces = 0;
  /// On the points of the columns this far: d is exact up to the distance cap.
  int points = 0;
};
FieldReach FieldReachOf(const FieldConfig& field, const GridConfig& grid, double resolution_m);

/// d and S' on the band of `surfaces` (TerrainFields) over the columns of `window` (grid
/// indices, x and y; CellBox::Whole for the whole map), from the cloud the surfaces were
/// built from, whose window must hold every column within FieldReachOf(...).points of them
/// (inside the grid). The parts' column_begin covers the window's columns only (x fastest).
/// A column's values do not depend on the window (each value reads only cells within the
/// reaches above): tile by tile with `num_threads` threads, peak scratch is one tile's dense
/// block per thread. `progress` (may be null) counts tiles (FieldTileCount of the window; the
/// caller begins the stage) and may stop the work: kCancelled. kResourceExhausted when the
/// band would exceed 2^32 cells.
Expected<TerrainFields::Parts> BuildFieldParts(const SurfaceMap& surfaces, const ColumnCloud& cloud,
                                               const CellBox& window, const FieldConfig& field,
                                               const GridConfig& grid, int num_threads,
                                               ProgressReporter* progress);

/// The tiles BuildFieldParts counts over `window`.
std::int64_t FieldTileCount(const CellBox& window);

/// BuildFieldParts over the whole grid, chunk by chunk, as TerrainFields.
Expected<TerrainFields> BuildTerrainFields(const SurfaceMap& surfaces, const ColumnCloud& cloud,
                                           const FieldConfig& field, const GridConfig& grid,
                                           int num_threads, ProgressReporter* progress);

}  // namespace strata::internal
