#pragma once
/// The Valid Ground Filter on a column-sorted cloud (the form terrain assessment uses).

#include "assessment/assessment_progress.hpp"
#include "assessment/column_cloud.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// How many columns of edge `column_size_m` away a point's neighbours within the filter's
/// radius may lie, on each axis: a point's flag depends on the points of these columns only.
int GroundFilterReach(const GroundFilterConfig& config, double column_size_m);

/// Sets cloud->valid to the rule of FilterValidGround (strata/assessment/ground_filter.hpp) for
/// every point of the columns of `targets` (grid indices, x and y, inside the cloud's window; null:
/// every column), the other points being left as they are. `column_size_m` is the edge of the
/// cloud's columns. The columns within GroundFilterReach of a target must be in the cloud's
/// window for its flags to be those of the whole cloud. `progress` (may be null) counts rows
/// of columns and may stop the filter: kCancelled, with cloud->valid incomplete.
Status FilterValidGroundInColumns(ColumnCloud* cloud, const GroundFilterConfig& config,
                                  double column_size_m, double step_tolerance_m, int num_threads,
                                  ProgressReporter* progress, const CellBox* targets = nullptr);

}  // namespace strata::internal
