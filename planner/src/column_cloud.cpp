#include "column_cloud.hpp"

#include <algorithm>
#include <numeric>

namespace strata::internal {
namespace {

ColumnCloud SortIntoWindow(const GridGeometry& g, const CellBox& window, const PointCloud& cloud,
                           [[maybe_unused]] int num_threads,  // OpenMP only.
                           std::vector<std::uint32_t>* source_index) {
  ColumnCloud out;
  out.x0 = window.min.x();
  out.y0 = window.min.y();
  out.nx = window.max.x() - window.min.x() + 1;
  out.ny = window.max.y() - window.min.y() + 1;
  const std::int64_t columns = std::int64_t{out.nx} * out.ny;
  std::vector<std::uint32_t> column_of(cloud.size());
  out.begin.assign(columns + 1, 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector2i column = ColumnOf(g, cloud[i]);
    const int ix = std::clamp(column.x(), window.min.x(), window.max.x());
    const int iy = std::clamp(column.y(), window.min.y(), window.max.y());
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

}  // namespace

ColumnCloud SortIntoColumns(const GridGeometry& g, const PointCloud& cloud, int num_threads,
                            std::vector<std::uint32_t>* source_index) {
  return SortIntoWindow(g, CellBox::Whole(g), cloud, num_threads, source_index);
}

ColumnCloud SortIntoColumnWindow(const GridGeometry& g, const CellBox& window,
                                 const PointCloud& cloud, int num_threads) {
  return SortIntoWindow(g, window, cloud, num_threads, nullptr);
}

PointCloud CropToColumns(const GridGeometry& g, const CellBox& window, const PointCloud& cloud,
                         Eigen::AlignedBox3d* bounds) {
  PointCloud out;
  for (const Eigen::Vector3f& p : cloud) {
    if (bounds != nullptr) bounds->extend(p.cast<double>());
    const Eigen::Vector2i column = ColumnOf(g, p);
    if (column.x() >= window.min.x() && column.x() <= window.max.x() &&
        column.y() >= window.min.y() && column.y() <= window.max.y()) {
      out.push_back(p);
    }
  }
  return out;
}

}  // namespace strata::internal
