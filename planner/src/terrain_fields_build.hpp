#pragma once
/// Computing the band-stored fields of an assessed map (strata/terrain_fields.hpp).

#include "assessment_progress.hpp"
#include "column_cloud.hpp"
#include "strata/status.hpp"
#include "strata/surface_map.hpp"
#include "strata/terrain_config.hpp"
#include "strata/terrain_fields.hpp"

namespace strata::internal {

/// d and S' on the band of `surfaces` (TerrainFields), from the cloud the surfaces were built
/// from, tile by tile with `num_threads` threads: peak scratch is one tile's dense block per
/// thread. `progress` (may be null) counts tiles (stage kFields) and may stop the work:
/// kCancelled. kResourceExhausted when the band would exceed 2^32 cells.
Expected<TerrainFields> BuildTerrainFields(const SurfaceMap& surfaces, const ColumnCloud& cloud,
                                           const FieldConfig& field, const GridConfig& grid,
                                           int num_threads, ProgressReporter* progress);

}  // namespace strata::internal
