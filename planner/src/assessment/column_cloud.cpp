#include "assessment/column_cloud.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

#include "parallel_internal.hpp"

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

void ThinColumns(ColumnCloud* cloud, const GridGeometry& g,
                 [[maybe_unused]] int num_threads) {  // OpenMP only.
  const std::int64_t columns = std::int64_t{cloud->nx} * cloud->ny;
  std::vector<std::uint8_t> keep(cloud->points.size(), 1);
  std::vector<std::uint32_t> kept(columns + 1, 0);
#pragma omp parallel num_threads(num_threads)
  {
    struct Key {
      std::int64_t x, y;
      std::uint32_t index;
    };
    std::vector<Key> run;
#pragma omp for schedule(dynamic, 1024)
    for (std::int64_t c = 0; c < columns; ++c) {
      const std::uint32_t end = cloud->begin[c + 1];
      // The column is sorted by z, so the points of one layer of cubes are a contiguous run;
      // within a run, the first point of each (x, y) cube stays.
      for (std::uint32_t i = cloud->begin[c]; i < end;) {
        const std::int64_t layer = ThinningCubeIndex(g, cloud->points[i].z(), 2);
        std::uint32_t j = i + 1;
        while (j < end && ThinningCubeIndex(g, cloud->points[j].z(), 2) == layer) ++j;
        if (j - i > 1) {
          run.clear();
          for (std::uint32_t k = i; k < j; ++k) {
            const Eigen::Vector3f& p = cloud->points[k];
            run.push_back({ThinningCubeIndex(g, p.x(), 0), ThinningCubeIndex(g, p.y(), 1), k});
          }
          std::sort(run.begin(), run.end(), [](const Key& a, const Key& b) {
            return std::tie(a.x, a.y, a.index) < std::tie(b.x, b.y, b.index);
          });
          for (std::size_t k = 1; k < run.size(); ++k) {
            if (run[k].x == run[k - 1].x && run[k].y == run[k - 1].y) keep[run[k].index] = 0;
          }
        }
        i = j;
      }
      std::uint32_t count = 0;
      for (std::uint32_t k = cloud->begin[c]; k < end; ++k) count += keep[k];
      kept[c + 1] = count;
    }
  }
  std::partial_sum(kept.begin(), kept.end(), kept.begin());
  if (kept.back() == cloud->points.size()) return;
  std::vector<Eigen::Vector3f> points(kept.back());
#pragma omp parallel for schedule(dynamic, 1024) num_threads(num_threads)
  for (std::int64_t c = 0; c < columns; ++c) {
    std::uint32_t out = kept[c];
    for (std::uint32_t k = cloud->begin[c]; k < cloud->begin[c + 1]; ++k) {
      if (keep[k]) points[out++] = cloud->points[k];
    }
  }
  cloud->points = std::move(points);
  cloud->begin = std::move(kept);
  cloud->valid.assign(cloud->points.size(), 0);
}

ColumnCloud SortIntoColumns(const GridGeometry& g, const PointCloud& cloud, int num_threads,
                            std::vector<std::uint32_t>* source_index) {
  return SortIntoWindow(g, CellBox::Whole(g), cloud, num_threads, source_index);
}

ColumnCloud SortIntoColumnWindow(const GridGeometry& g, const CellBox& window,
                                 const PointCloud& cloud, int num_threads) {
  return SortIntoWindow(g, window, cloud, num_threads, nullptr);
}

PointCloud CropToColumns(const GridGeometry& g, const CellBox& window, const PointCloud& cloud,
                         int num_threads, Eigen::AlignedBox3d* bounds) {
  // Most points lie far from the window: a float test against the window grown by a cell
  // rejects them before ColumnOf's exact arithmetic decides the rest.
  const auto edge = [&](int axis, int column) {
    return static_cast<float>(g.origin_m[axis] + column * g.resolution_m);
  };
  const float x_lo = edge(0, window.min.x() - 1), x_hi = edge(0, window.max.x() + 2);
  const float y_lo = edge(1, window.min.y() - 1), y_hi = edge(1, window.max.y() + 2);
  // Points beyond the grid belong to its border columns.
  const bool open_x_lo = window.min.x() == 0, open_x_hi = window.max.x() == g.size.x() - 1;
  const bool open_y_lo = window.min.y() == 0, open_y_hi = window.max.y() == g.size.y() - 1;
  // Two passes' worth of work in one: each thread crops a contiguous part of the cloud, and
  // the parts are joined in order.
  const int threads = ResolveThreadCount(num_threads);
  std::vector<PointCloud> parts(threads);
  std::vector<Eigen::Vector3f> lows(
      threads, Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity()));
  std::vector<Eigen::Vector3f> highs(threads, -lows.front());
#pragma omp parallel for schedule(static, 1) num_threads(threads)
  for (int t = 0; t < threads; ++t) {
    const std::size_t begin = cloud.size() * t / threads;
    const std::size_t end = cloud.size() * (t + 1) / threads;
    Eigen::Vector3f lo = lows[t], hi = highs[t];
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3f& p = cloud[i];
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      if ((p.x() < x_lo && !open_x_lo) || (p.x() > x_hi && !open_x_hi) ||
          (p.y() < y_lo && !open_y_lo) || (p.y() > y_hi && !open_y_hi)) {
        continue;
      }
      const Eigen::Vector2i column = ColumnOf(g, p);
      if (column.x() >= window.min.x() && column.x() <= window.max.x() &&
          column.y() >= window.min.y() && column.y() <= window.max.y()) {
        parts[t].push_back(p);
      }
    }
    lows[t] = lo;
    highs[t] = hi;
  }
  PointCloud out = std::move(parts.front());
  for (int t = 1; t < threads; ++t) out.insert(out.end(), parts[t].begin(), parts[t].end());
  Eigen::Vector3f lo = lows.front(), hi = highs.front();
  for (int t = 1; t < threads; ++t) {
    lo = lo.cwiseMin(lows[t]);
    hi = hi.cwiseMax(highs[t]);
  }
  if (bounds != nullptr && !cloud.empty()) {
    bounds->extend(lo.cast<double>());
    bounds->extend(hi.cast<double>());
  }
  return out;
}

}  // namespace strata::internal
