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

/// The ground a reference point p stands on, as a continuous function of p: bilinear
/// interpolation between the four nearest column centres of each column's plane-fit centre
/// height (and, when clearance_cap_m > 0, of the lowest ceiling clearance of the column and
/// its 8 neighbours, capped at clearance_cap_m: a ceiling is felt half a cell before the body
/// is under it; 0 skips the clearance), taking in every column the
/// surface whose ground is nearest to p.z − reference_height_m. Corners whose ground is more
/// than 0.5 m from that height (another level: a ledge, a drop) or that have no surface get no
/// weight and the rest are renormalised, so the ground does not slope into a drop; if every
/// corner is that far, all are used. Returns false when none of the four columns has a surface
/// or p lies outside the grid.
bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample);

/// Distance from p to the rim of the traversable region [m], a continuous function of p:
/// bilinear interpolation between the four nearest column centres of each column's
/// SurfaceGraph::edge_distance at p's level (the node within 0.5 m of p.z −
/// reference_height_m), a column without such a node counting −0.5·r (its centre lies half a
/// cell outside the rim). The rim itself is at 0. Writes the gradient wrt (x, y).
double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p,
                          Eigen::Vector2d* gradient);

}  // namespace strata
