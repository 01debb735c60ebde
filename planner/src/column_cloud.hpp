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

#include "strata/grid.hpp"
#include "strata/point_cloud.hpp"

namespace strata::internal {

struct ColumnCloud {
  int nx = 0;                           ///< Columns along x.
  int ny = 0;                           ///< Columns along y.
  std::vector<std::uint32_t> begin;     ///< nx·ny + 1 offsets into points, x fastest.
  std::vector<Eigen::Vector3f> points;  ///< Column by column, each by ascending z.
  std::vector<std::uint8_t> valid;      ///< Valid Ground Filter flag per point (1 = valid).

  std::int64_t ColumnIndex(int ix, int iy) const { return ix + std::int64_t{nx} * iy; }
  std::span<const Eigen::Vector3f> Column(std::int64_t c) const {
    return {points.data() + begin[c], points.data() + begin[c + 1]};
  }
  std::size_t MemoryBytes() const {
    return begin.capacity() * sizeof(std::uint32_t) + points.capacity() * sizeof(Eigen::Vector3f) +
           valid.capacity();
  }
};

/// Groups `cloud` by the columns (x, y cells) of `geometry`; a point outside the grid goes to
/// the nearest border column. Points of equal height keep their order in `cloud`, so the
/// result does not depend on the thread count. `source_index`, when non-null, receives for
/// every sorted point its index in `cloud`. `valid` is sized and zeroed. Precondition: fewer
/// than 2^32 points.
ColumnCloud SortIntoColumns(const GridGeometry& geometry, const PointCloud& cloud, int num_threads,
                            std::vector<std::uint32_t>* source_index = nullptr);

/// Grid layer of height z, clamped into [0, nz − 1].
inline int ClampedLayer(const GridGeometry& g, float z) {
  const int layer = static_cast<int>(std::floor((z - g.origin_m.z()) / g.resolution_m));
  return std::clamp(layer, 0, g.size.z() - 1);
}

}  // namespace strata::internal
