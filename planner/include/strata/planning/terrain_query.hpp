#pragma once
/// Continuous queries of the terrain around a point: the smoothed ground height and ceiling
/// clearance under it (SampleGround) and its distance to the rim of the traversable region
/// (SampleEdgeDistance). The optimiser's costs (trajectory_costs.hpp) and the final
/// verification (trajectory_verifier.hpp) share them and nothing else, so the last check
/// depends on the map, not on the optimiser.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/surface_graph.hpp"

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
/// (the same constraint point in the optimiser's next evaluation): while the point stays
/// between the same four column centres and its ground height in the range where each
/// corner's choice stands, SampleGround reuses them instead of scanning the columns again.
struct GroundChoice {
  Eigen::Vector2i cell = Eigen::Vector2i::Constant(-2);  ///< Lower-left corner column; none yet.
  /// The points (x, y) whose lower-left corner column is `cell`, a nanometre inside.
  Eigen::AlignedBox2d area;
  double low_m = 0, high_m = -1;  ///< The choices stand for ground heights strictly between.
  const ColumnSurface* corner[2][2] = {};  ///< [dy][dx], null where a column has no surface.
  /// The lowest and highest plane-centre height of the corners (low > high without any).
  double center_low_m = 0, center_high_m = -1;
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
/// or p lies outside the grid. With `choice` (may be null; from the same model), the same
/// result from fewer lookups while the point stays where the choice stands, and the choice
/// made here when it does not.
bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample, GroundChoice* choice = nullptr);

/// Whether SampleGround at p, with `choice`, reuses the choice and gives a ground height
/// within band_m of p.z − reference_height_m, or no ground; decided without sampling, from
/// the choice's area and range and its corners' heights (the sample is a weighted mean of some
/// of them), a nanometre inside each bound. False where that is not certain.
bool GroundWithinBand(const GroundChoice& choice, const Eigen::Vector3d& p,
                      double reference_height_m, double band_m);

/// The lower-left column of the four whose centres SampleGround blends at (x, y) = p (by the
/// same arithmetic; GroundChoice::cell): p lies in their square. For a p of the grid, each
/// coordinate is p's column's or the one before; it may be -1 or the grid's size at its edges.
Eigen::Vector2i BlendCell(const GridGeometry& grid, const Eigen::Vector2d& p);

/// The lowest and highest ground height h_G that SampleGround gives with the corners of
/// choice.cell over the points whose (x, y) lie in `area` and whose ground height
/// p.z − reference height lies in [ground_low_m, ground_high_m], into *low_m and *high_m (a
/// choice made by SampleGround on `model`). `area` may reach up to reach_m past choice.area,
/// where the same corners' blend is continued. While the same corners carry the same weights,
/// h_G is a quotient of two bilinear functions of (x, y) with a positive denominator, monotone
/// along x and along y, so its extremes over a box are at the box's corners. Where a corner
/// changes surface inside the band (h_G jumps there), the range is the union over the surfaces
/// it may take. False where that is not certain: a corner's weight switches inside the band,
/// the weights can vanish in `area`, or the corners may take over 16 combinations of surfaces.
bool GroundHeightRange(const TerrainModel& model, const GroundChoice& choice,
                       const Eigen::AlignedBox2d& area, double reach_m, double ground_low_m,
                       double ground_high_m, double* low_m, double* high_m);

/// Where SampleEdgeDistance found p's column so far inside the region that the rim is beyond
/// reach_m whatever p's place in it: the column and the open band of ground heights,
/// p.z − reference_height_m, over which its level is the same node. For every point in both
/// it returns the same value and a zero gradient. Empty (ix = -1) where p was not that deep.
struct DeepInside {
  int ix = -1;
  int iy = -1;
  double ground_low = 0;
  double ground_high = 0;
};

/// Signed distance from p to the rim of the traversable region at p's level [m], measured in
/// x, y: the region is the union of the grid columns that hold a SurfaceGraph node whose
/// ground lies within SurfaceGraph::kLevelGapM of p.z − reference_height_m, positive inside
/// it, negative outside, 0 on the rim. Exact (the distance to the nearest square of the
/// other kind) wherever it is within `reach_m` (at least a cell) of the rim, and clamped to
/// ± the exact range beyond, so that a penalty on e < reach_m sees the verifier's
/// column-by-column test exactly: a point cutting a corner of a missing column is outside.
/// Continuous in p; writes the gradient wrt (x, y) (0 where clamped), and with `deep` where p
/// was deep inside.
double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p, double reach_m,
                          Eigen::Vector2d* gradient, DeepInside* deep = nullptr);

/// Whether p lies in `deep`'s column and band, computed as SampleEdgeDistance locates p: true
/// only where SampleEdgeDistance(p) with the same reach_m returns what it did for `deep`.
bool IsDeepInside(const SurfaceGraph& graph, const Eigen::Vector3d& p, const DeepInside& deep);

}  // namespace strata
