#include "strata/assessment/ground_filter.hpp"

#include <algorithm>
#include <cmath>

#include "assessment/ground_filter_internal.hpp"
#include "parallel_internal.hpp"

namespace strata {
namespace internal {
namespace {

// The rule of FilterValidGround for one neighbour q of p.
class ElevationRule {
 public:
  ElevationRule(const GroundFilterConfig& config, double step_tolerance_m)
      : radius_sq_(static_cast<float>(config.radius_m * config.radius_m)),
        tan_tilt_(std::tan(config.max_tilt_rad)),
        tolerance_(config.height_tolerance_m),
        step_(step_tolerance_m) {}

  // Only points higher than this above p can block it.
  double tolerance() const { return tolerance_; }

  bool Blocks(const Eigen::Vector3f& p, const Eigen::Vector3f& q) const {
    // The squared distance in float, summed x, y, z, and compared strictly: the ball a kd-tree
    // radius search (FLANN's L2_Simple) returns, so the result does not depend on how the
    // neighbours are found.
    float squared = 0;
    float d = p.x() - q.x();
    squared += d * d;
    d = p.y() - q.y();
    squared += d * d;
    d = p.z() - q.z();
    squared += d * d;
    if (!(squared < radius_sq_)) return false;
    const double raw_rise = double{q.z()} - p.z();
    const double rise = raw_rise - tolerance_;
    if (rise <= 0.0) return false;  // Only what lies above p can block it.
    const double dxy = std::hypot(double{q.x()} - p.x(), double{q.y()} - p.y());
    // A one-step riser beside p (not a wall over it) is a step of the staircase a voxelised
    // map makes of every slope.
    if (raw_rise <= step_ && dxy >= 0.5 * step_) return false;
    // atan(rise / dxy) < θ  <=>  rise < tan(θ)·dxy for rise > 0, dxy >= 0 and θ < π/2.
    return !(rise < tan_tilt_ * dxy);
  }

 private:
  float radius_sq_;
  double tan_tilt_;
  double tolerance_;
  double step_;
};

// The part of one neighbour column still to be scanned for the current point of the centre
// column: points at or below p + tolerance are behind `next` for good, since p only rises.
struct NeighbourRange {
  const Eigen::Vector3f* next;
  const Eigen::Vector3f* end;
};

}  // namespace

int GroundFilterReach(const GroundFilterConfig& config, double column_size_m) {
  return static_cast<int>(std::ceil(config.radius_m / column_size_m));
}

Status FilterValidGroundInColumns(ColumnCloud* cloud, const GroundFilterConfig& config,
                                  double column_size_m, double step_tolerance_m, int num_threads,
                                  ProgressReporter* progress, const CellBox* targets) {
  num_threads = ResolveThreadCount(num_threads);
  const ElevationRule rule(config, step_tolerance_m);
  const int reach = GroundFilterReach(config, column_size_m);
  const double max_rise = config.radius_m + 1e-3;  // Above this, q is outside the ball.
  const CellBox window = cloud->Window();
  const CellBox todo = targets != nullptr ? *targets : window;
  constexpr int kRowsPerUnit = 4;  // Progress and cancellation granularity.

#pragma omp parallel num_threads(num_threads)
  {
    std::vector<NeighbourRange> ranges;
#pragma omp for schedule(dynamic, 1)
    for (int row0 = todo.min.y(); row0 <= todo.max.y(); row0 += kRowsPerUnit) {
      if (progress != nullptr && progress->stopped()) continue;
      for (int iy = row0; iy <= std::min(todo.max.y(), row0 + kRowsPerUnit - 1); ++iy) {
        for (int ix = todo.min.x(); ix <= todo.max.x(); ++ix) {
          const std::int64_t c = cloud->ColumnIndex(ix, iy);
          if (cloud->begin[c] == cloud->begin[c + 1]) continue;
          ranges.clear();
          for (int y = std::max(window.min.y(), iy - reach);
               y <= std::min(window.max.y(), iy + reach); ++y) {
            for (int x = std::max(window.min.x(), ix - reach);
                 x <= std::min(window.max.x(), ix + reach); ++x) {
              const std::int64_t n = cloud->ColumnIndex(x, y);
              if (cloud->begin[n] == cloud->begin[n + 1]) continue;
              ranges.push_back({cloud->points.data() + cloud->begin[n],
                                cloud->points.data() + cloud->begin[n + 1]});
            }
          }
          for (std::uint32_t i = cloud->begin[c]; i < cloud->begin[c + 1]; ++i) {
            const Eigen::Vector3f& p = cloud->points[i];
            bool blocked = false;
            for (NeighbourRange& range : ranges) {
              while (range.next != range.end &&
                     !(double{range.next->z()} - p.z() - rule.tolerance() > 0.0)) {
                ++range.next;
              }
              for (const Eigen::Vector3f* q = range.next;
                   q != range.end && double{q->z()} - p.z() <= max_rise; ++q) {
                if (rule.Blocks(p, *q)) {
                  blocked = true;
                  break;
                }
              }
              if (blocked) break;
            }
            cloud->valid[i] = blocked ? 0 : 1;
          }
        }
      }
      if (progress != nullptr) progress->Advance(kRowsPerUnit);
    }
  }
  if (progress != nullptr && progress->stopped()) {
    return Error{ErrorCode::kCancelled, "terrain assessment cancelled during the ground filter"};
  }
  return Status::Ok();
}

}  // namespace internal

std::vector<std::uint8_t> FilterValidGround(const PointCloud& cloud,
                                            const GroundFilterConfig& config, int num_threads,
                                            double step_tolerance_m) {
  std::vector<std::uint8_t> valid(cloud.size(), 0);
  if (cloud.empty()) return valid;
  // Columns one radius wide, so each point's neighbours lie in its own column and the 8
  // around it; wider where that would take more than kMaxColumns (a cloud with a stray point
  // far away), which costs time, never correctness.
  constexpr double kMaxColumns = 1e7;
  Eigen::AlignedBox3d bounds;
  for (const Eigen::Vector3f& p : cloud) bounds.extend(p.cast<double>());
  const Eigen::Vector3d extent = bounds.sizes();
  GridGeometry columns;
  columns.origin_m = bounds.min();
  columns.resolution_m =
      std::max(config.radius_m, std::sqrt(extent.x() * extent.y() / kMaxColumns));
  columns.resolution_m =
      std::max({columns.resolution_m, extent.x() / kMaxColumns, extent.y() / kMaxColumns});
  columns.size = Eigen::Vector3i(static_cast<int>(extent.x() / columns.resolution_m) + 1,
                                 static_cast<int>(extent.y() / columns.resolution_m) + 1, 1);
  std::vector<std::uint32_t> source;
  internal::ColumnCloud sorted = internal::SortIntoColumns(columns, cloud, num_threads, &source);
  internal::FilterValidGroundInColumns(&sorted, config, columns.resolution_m, step_tolerance_m,
                                       num_threads, nullptr);
  for (std::size_t k = 0; k < source.size(); ++k) valid[source[k]] = sorted.valid[k];
  return valid;
}

}  // namespace strata
