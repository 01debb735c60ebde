#pragma once
/// The Valid Ground Filter on a column-sorted cloud (the form terrain assessment uses).

#include "assessment_progress.hpp"
#include "column_cloud.hpp"
#include "strata/status.hpp"
#include "strata/terrain_config.hpp"

namespace strata::internal {

/// Sets cloud->valid to the rule of FilterValidGround (strata/ground_filter.hpp) for every
/// point. `column_size_m` is the edge of the cloud's columns. `progress` (may be null) counts
/// rows of columns and may stop the filter: kCancelled, with cloud->valid incomplete.
Status FilterValidGroundInColumns(ColumnCloud* cloud, const GroundFilterConfig& config,
                                  double column_size_m, double step_tolerance_m, int num_threads,
                                  ProgressReporter* progress);

}  // namespace strata::internal
