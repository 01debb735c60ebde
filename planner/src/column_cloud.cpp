#include "column_cloud.hpp"

#include <algorithm>
#include <numeric>

namespace strata::internal {

ColumnCloud SortIntoColumns(const GridGeometry& g, const PointCloud& cloud,
                            [[maybe_unused]] int num_threads,  // OpenMP only.
                            std::vector<std::uint32_t>* source_index) {
  ColumnCloud out;
  out.nx = g.size.x();
  out.ny = g.size.y();
  const std::int64_t columns = g.LayerCellCount();
  std::vector<std::uint32_t> column_of(cloud.size());
  out.begin.assign(columns + 1, 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    // GridGeometry::CellOf's arithmetic, so a point lands in the column every other stage
    // computes for it.
    const Eigen::Vector3i cell = g.CellOf(cloud[i].cast<double>());
    const int ix = std::clamp(cell.x(), 0, out.nx - 1);
    const int iy = std::clamp(cell.y(), 0, out.ny - 1);
    column_of[i] = static_cast<std::uint32_t>(out.ColumnIndex(ix, iy));
    ++out.begin[column_of[i] + 1];
  }
  std::partial_sum(out.begin.begin(), out.begin.end(), out.begin.begin());
  std::vector<std::uint32_t> order(cloud.size());
  {
    std::vector<std::uint32_t> next(out.begin.begin(), out.begin.end() - 1);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      order[next[column_of[i]]++] = static_cast<std::uint32_t>(i);
    }
  }
  column_of = {};  // Free it before the sorted copy is made.

#pragma omp parallel for schedule(dynamic, 1024) num_threads(num_threads)
  for (std::int64_t c = 0; c < columns; ++c) {
    // Stable: points of equal height stay in input order whatever the thread count.
    std::stable_sort(order.begin() + out.begin[c], order.begin() + out.begin[c + 1],
                     [&](std::uint32_t a, std::uint32_t b) { return cloud[a].z() < cloud[b].z(); });
  }
  out.points.resize(cloud.size());
  for (std::size_t k = 0; k < order.size(); ++k) out.points[k] = cloud[order[k]];
  out.valid.assign(cloud.size(), 0);
  if (source_index != nullptr) *source_index = std::move(order);
  return out;
}

}  // namespace strata::internal
