#pragma once
/// ReassessRegion's parts, for an edit that reads only the points and the model around it
/// (strata/io/tiled_edit.hpp) as well as for one that holds the whole cloud.

#include <string>

#include <Eigen/Geometry>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// The columns an edit touching `touched` can change, and those whose points their
/// reassessment reads (docs/design.md, "Map edits"). All on the base's grid, z: 0 to 0.
struct EditReach {
  CellBox touched;           ///< Every point the edit adds or drops lies in these columns.
  CellBox flags_changed;     ///< Valid flags of points may change here.
  CellBox surfaces_changed;  ///< Surfaces may change here.
  CellBox fields_changed;    ///< Fields may change here: the columns reassessed.
  CellBox crop;              ///< The edited cloud's points the reassessment reads.
  CellBox base_crop;         ///< The base cloud's points it reads (for the old valid flags).
  CellBox surfaces_read;     ///< The surfaces (base's or new) the new fields read.
};

/// The reach of an edit of `touched_m` [m] (finite, not empty) on a model of `config` on the
/// grid `g`, of a cloud with the vertical quantum `quantum_m`.
EditReach ReachOfEdit(const AssessmentConfig& config, const GridGeometry& g, double quantum_m,
                      const Eigen::AlignedBox3d& touched_m);

/// kInvalidInput unless `touched_m` is finite and not empty.
Status ValidateTouched(const Eigen::AlignedBox3d& touched_m);

/// Why the grid of `summary` (its bounds and quantum) is not `g` (AssessmentGrid with
/// `config`), in words; empty when it is.
std::string GridChange(const GridGeometry& g, const AssessmentSummary& summary,
                       const GridConfig& config);

/// ReassessRegion's local work. `summary` is the base's with the edited cloud's
/// input_points, cloud_bounds_m and vertical_quantum_m, on the base's grid (GridChange
/// empty). `near_edited` holds the edited cloud's points in reach.crop (CropToColumns), in
/// their order, `near_base` the base cloud's in reach.base_crop. `base` must hold its
/// surfaces in reach.surfaces_read and its fields outside reach.fields_changed wherever the
/// result is read; the summary's counts change by what the edit changed.
Expected<Reassessment> ReassessNear(const TerrainModel& base, const EditReach& reach,
                                    AssessmentSummary summary, const PointCloud& near_edited,
                                    const PointCloud& near_base, const AssessmentControl& control);

}  // namespace strata::internal
