#pragma once
/// Continuous queries of the terrain around a point: the smoothed ground height and ceiling
/// clearance under it (SampleGround) and its distance to the rim of the traversable region
/// (SampleEdgeDistance). The optimiser's costs (trajectory_costs.hpp) and the final
/// verification (trajectory_verifier.hpp) share them and nothing else, so the last check
/// depends on the map, not on the optimiser.
#include <Eigen/Core>

#include "strata/surface_graph.hpp"
#include "strata/surface_map.hpp"
#include "strata/terrain_model.hpp"

namespace strata {

/// The ground under a point, smoothed across columns (see SampleGround).
struct GroundSample {
  double height_m = 0;                                           ///< h_G [m].
  Eigen::Vector2d height_gradient = Eigen::Vector2d::Zero();     ///< ∂h_G/∂(x, y) [-].
  double clearance_m = 0;                                        ///< Ceiling clearance [m], capped.
  Eigen::Vector2d clearance_gradient = Eigen::Vector2d::Zero();  ///< ∂clearance/∂(x, y).
  /// The surface of p's own column whose ground is nearest to p.z − reference height (the one
  /// p stands on); when the column has none (a hole in the map), the surface of the corner
  /// with the largest interpolation weight.
  const ColumnSurface* surface = nullptr;
};

/// The corner surfaces a ground sample last chose, for the next sample at about the same point
/// (the same trajectory sample in the optimiser's next evaluation): while the point stays
/// between the same four column centres and its ground height in the range where each
/// corner's choice stands, SampleGround reuses them instead of scanning the columns again.
struct GroundCellMemo {
  Eigen::Vector2i cell = Eigen::Vector2i::Constant(-2);  ///< Lower-left corner column; none yet.
  double low_m = 0, high_m = -1;  ///< The choices stand for ground heights strictly between.
  const ColumnSurface* corner[2][2] = {};  ///< [dy][dx], null where a column has no surface.
  /// The lowest clearance around each corner, computed with `clearance_cap_m` (< 0: not yet).
  double lowest_clearance_m[2][2] = {};
  double clearance_cap_m = -1;
};

/// The ground a reference point p stands on, as a continuous function of p: bilinear
/// interpolation between the four nearest column centres of each column's plane-fit centre
/// height (and, when clearance_cap_m > 0, of the lowest ceiling clearance of the column and
/// its 8 neighbours, capped at clearance_cap_m: a ceiling is felt half a cell before the body
/// is under it; 0 skips the clearance), taking in every column the
/// surface whose ground is nearest to p.z − reference_height_m. Corners whose ground is more
/// than 0.5 m from that height (another level: a ledge, a drop) or that have no surface get no
/// weight and the rest are renormalised, so the ground does not slope into a drop; if every
/// corner is that far, all are used. Returns false when none of the four columns has a surface
/// or p lies outside the grid. With `memo` (may be null; from the same model), the same result
/// from fewer lookups while the point stays where the memo's choices stand.
bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample, GroundCellMemo* memo = nullptr);

/// Where SampleEdgeDistance last found a point deep inside the traversable region, for the
/// next sample at about the same point: while the point stays in that column with its ground
/// height where the column's node choice stands, the answer is the same clamped distance.
struct EdgeCellMemo {
  Eigen::Vector2i cell = Eigen::Vector2i::Constant(-2);  ///< The column; none yet.
  double low_m = 0, high_m = -1;  ///< Deep inside for ground heights strictly between.
  double reach_m = -1;            ///< The reach it was found with.
};

/// Signed distance from p to the rim of the traversable region at p's level [m], measured in
/// x, y: the region is the union of the grid columns that hold a SurfaceGraph node whose
/// ground lies within SurfaceGraph::kLevelGapM of p.z − reference_height_m, positive inside
/// it, negative outside, 0 on the rim. Exact (the distance to the nearest square of the
/// other kind) wherever it is within `reach_m` (at least a cell) of the rim, and clamped to
/// ± the exact range beyond, so that a penalty on e < reach_m sees the verifier's
/// column-by-column test exactly: a point cutting a corner of a missing column is outside.
/// Continuous in p; writes the gradient wrt (x, y) (0 where clamped). With `memo` (may be
/// null; from the same graph), the same result from fewer lookups deep inside.
double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p, double reach_m,
                          Eigen::Vector2d* gradient, EdgeCellMemo* memo = nullptr);

}  // namespace strata
