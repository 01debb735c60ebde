#pragma once
/// Point queries on an assessed map that only tests need (header-only, test code only), written
/// on TerrainModel's public surfaces. Whether a robot can stand somewhere is not decided here:
/// that has one definition, the SurfaceGraph's nodes for its TraversabilityParams, and
/// HasNodeInCell asks the graph.

#include <algorithm>
#include <optional>
#include <span>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata::test_util {

/// The surfaces (levels) in the column holding p's x and y, lowest first; empty outside.
inline std::span<const ColumnSurface> LevelsAt(const TerrainModel& model,
                                               const Eigen::Vector3d& p) {
  const GridGeometry& g = model.grid();
  const Eigen::Vector3i c = g.CellOf(p);
  if (c.x() < 0 || c.y() < 0 || c.x() >= g.size.x() || c.y() >= g.size.y()) return {};
  return model.surfaces().Column(c.x(), c.y());
}

/// The surface p projects down onto (the highest one at or below p's cell), if any.
inline const ColumnSurface* SurfaceBelow(const TerrainModel& model, const Eigen::Vector3d& p) {
  const GridGeometry& g = model.grid();
  const Eigen::Vector3i c = g.CellOf(p);
  if (c.x() < 0 || c.y() < 0 || c.x() >= g.size.x() || c.y() >= g.size.y() || c.z() < 0) {
    return nullptr;
  }
  return model.surfaces().SurfaceBelow(c.x(), c.y(), std::min(c.z(), g.size.z() - 1));
}

/// Height of the valid ground directly below p [m], or nothing when p is inside an obstacle,
/// outside the grid, or above a surface that is not valid ground.
inline std::optional<double> GroundHeightBelow(const TerrainModel& model,
                                               const Eigen::Vector3d& p) {
  const ColumnSurface* s = SurfaceBelow(model, p);
  if (s == nullptr || !s->valid) return std::nullopt;
  return s->ground_z_m;
}

/// Whether `graph` has a node whose reference point lies in grid cell `cell`: the robot of the
/// graph's TraversabilityParams can stand there.
inline bool HasNodeInCell(const SurfaceGraph& graph, const Eigen::Vector3i& cell) {
  for (const int node : graph.ColumnNodes(cell.x(), cell.y())) {
    if (graph.cell(node) == cell) return true;
  }
  return false;
}

}  // namespace strata::test_util
