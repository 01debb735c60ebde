#pragma once
/// The cloud regrouped by grid column, each column sorted by height: the one neighbourhood
/// structure of terrain assessment. The Valid Ground Filter, the column surfaces, the plane
/// fits and the occupancy of each tile's distance transform are all contiguous scans of a few
/// columns, so assessment needs no kd-tree and its work grows with the points and the columns
/// that hold them, never with the volume of the bounding box.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/assessment/grid.hpp"
#include "strata/point_cloud.hpp"

namespace strata::internal {

/// The columns of a window of the grid: all of it (terrain assessment) or the columns around
/// an edit (ReassessRegion, strata/assessment/map_edit.hpp). Columns are named by their grid
/// indices.
struct ColumnCloud {
  int x0 = 0;                           ///< Grid column x of the window's first column.
  int y0 = 0;                           ///< Grid column y of the window's first column.
  int nx = 0;                           ///< Columns along x.
  int ny = 0;                           ///< Columns along y.
  std::vector<std::uint32_t> begin;     ///< nx·ny + 1 offsets into points, x fastest.
  std::vector<Eigen::Vector3f> points;  ///< Column by column, each by ascending z.
  std::vector<std::uint8_t> valid;      ///< Valid Ground Filter flag per point (1 = valid).

  /// Index of grid column (ix, iy), which must lie in the window, in `begin`.
  std::int64_t ColumnIndex(int ix, int iy) const {
    return (ix - x0) + std::int64_t{nx} * (iy - y0);
  }
  /// The window's columns (grid indices; layer 0 only).
  CellBox Window() const { return {{x0, y0, 0}, {x0 + nx - 1, y0 + ny - 1, 0}}; }
  std::span<const Eigen::Vector3f> Column(std::int64_t c) const {
    return {points.data() + begin[c], points.data() + begin[c + 1]};
  }
  std::size_t MemoryBytes() const {
    return begin.capacity() * sizeof(std::uint32_t) + points.capacity() * sizeof(Eigen::Vector3f) +
           valid.capacity();
  }
};

/// The column (x, y cell) of `geometry` a point belongs to: its cell, or the nearest border
/// column for a point outside the grid. Every stage assigns points to columns through this.
inline Eigen::Vector2i ColumnOf(const GridGeometry& g, const Eigen::Vector3f& p) {
  const Eigen::Vector3i cell = g.CellOf(p.cast<double>());
  return {std::clamp(cell.x(), 0, g.size.x() - 1), std::clamp(cell.y(), 0, g.size.y() - 1)};
}

/// Groups `cloud` by the columns (x, y cells) of `geometry` (ColumnOf). Points of equal
/// height keep their order in `cloud`, so the result does not depend on the thread count.
/// `source_index`, when non-null, receives for every sorted point its index in `cloud`.
/// `valid` is sized and zeroed. Precondition: fewer than 2^32 points.
ColumnCloud SortIntoColumns(const GridGeometry& geometry, const PointCloud& cloud, int num_threads,
                            std::vector<std::uint32_t>* source_index = nullptr);

/// The same for the columns of `window` (x, y of a CellBox of `geometry`, inside the grid):
/// the points of `cloud` (e.g. from CropToColumns) whose column lies outside the window go to
/// the window's nearest column. A column's points are sorted as SortIntoColumns sorts them
/// when `cloud` holds them in the same order.
ColumnCloud SortIntoColumnWindow(const GridGeometry& geometry, const CellBox& window,
                                 const PointCloud& cloud, int num_threads);

/// Cubes per grid cell edge in ThinColumns: a column keeps at most one point per cube of a
/// cell edge / 8 (2.5 cm at 0.2 m), finer than any lattice the assessment resolves.
inline constexpr int kThinningCubesPerCell = 8;

/// The index along `axis` (0 x, 1 y, 2 z) of the cube of ThinColumns holding a point whose
/// coordinate there is `value` [m]: cubes of edge g.resolution_m / kThinningCubesPerCell laid
/// from the grid's origin. The one definition of the cubes, which a scan's points are thinned
/// by too (ApplyEdits, strata/assessment/map_edit.hpp).
inline std::int64_t ThinningCubeIndex(const GridGeometry& g, float value, int axis) {
  const double leaf = g.resolution_m / kThinningCubesPerCell;
  return static_cast<std::int64_t>(std::floor((value - g.origin_m[axis]) / leaf));
}

/// Keeps, in every column, the first point (lowest, then earliest) of each cube of edge
/// g.resolution_m / kThinningCubesPerCell (cubes laid from the grid's origin), in order, and
/// resizes `valid`. The Valid Ground Filter scans the points above each point in the columns
/// around it, so a dense or duplicated cloud (a sensor that dwelt on one spot, or an upload of
/// one point repeated) would cost the square of its points there; thinned, the work per point
/// is bounded by the cubes of its neighbourhood. A cloud with at most one point per cube (the
/// shared maps, every lattice coarser than a cube) is unchanged. A column's result depends on
/// its own points only, so a window (SortIntoColumnWindow) thins its columns as the whole grid
/// does.
void ThinColumns(ColumnCloud* cloud, const GridGeometry& g, int num_threads);

/// The points of `cloud` whose column (ColumnOf) lies in `window` (x, y), in their order in
/// `cloud`: one pass, shared by `num_threads` threads (0: every core). `bounds`, when
/// non-null, is extended by every point of `cloud`.
PointCloud CropToColumns(const GridGeometry& geometry, const CellBox& window,
                         const PointCloud& cloud, int num_threads,
                         Eigen::AlignedBox3d* bounds = nullptr);

/// Grid layer of height z, clamped into [0, nz − 1].
inline int ClampedLayer(const GridGeometry& g, float z) {
  const int layer = static_cast<int>(std::floor((z - g.origin_m.z()) / g.resolution_m));
  return std::clamp(layer, 0, g.size.z() - 1);
}

}  // namespace strata::internal
