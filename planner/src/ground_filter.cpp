#include "strata/ground_filter.hpp"

#include <cmath>

#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include "parallel_internal.hpp"

namespace strata {
namespace {

// Receives the kd-tree's neighbours of one point p as the search finds them and applies the
// rule to each; the first neighbour that blocks p ends the search (worstDist() < 0 prunes every
// remaining branch). This is FLANN's own result-set hook: no neighbour list is ever built.
class ElevationCheck final : public flann::ResultSet<float> {
 public:
  ElevationCheck(const PointCloud& cloud, const Eigen::Vector3f& p, float radius_sq,
                 double tan_tilt, double tolerance, double step)
      : cloud_(cloud),
        p_(p),
        radius_sq_(radius_sq),
        tan_tilt_(tan_tilt),
        tolerance_(tolerance),
        step_(step) {}

  bool full() const override { return blocked_; }
  float worstDist() const override { return blocked_ ? -1.0f : radius_sq_; }
  void addPoint(float /*squared_distance*/, size_t index) override {
    const Eigen::Vector3f& q = cloud_[index];
    const double raw_rise = double{q.z()} - p_.z();
    const double rise = raw_rise - tolerance_;
    if (rise <= 0.0) return;  // Only what lies above p can block it.
    const double dxy = std::hypot(double{q.x()} - p_.x(), double{q.y()} - p_.y());
    // A one-step riser beside p (not a wall over it) is a step of the staircase a voxelised
    // map makes of every slope.
    if (raw_rise <= step_ && dxy >= 0.5 * step_) return;
    // atan(rise / dxy) < θ  <=>  rise < tan(θ)·dxy for rise > 0, dxy >= 0 and θ < π/2.
    if (!(rise < tan_tilt_ * dxy)) blocked_ = true;
  }
  bool blocked() const { return blocked_; }

 private:
  const PointCloud& cloud_;
  const Eigen::Vector3f& p_;
  const float radius_sq_;
  const double tan_tilt_;
  const double tolerance_;
  const double step_;
  bool blocked_ = false;
};

}  // namespace

std::vector<std::uint8_t> FilterValidGround(const PointCloud& cloud,
                                            const GroundFilterConfig& config, int num_threads,
                                            double step_tolerance_m) {
  const auto n = static_cast<std::int64_t>(cloud.size());
  std::vector<std::uint8_t> valid(cloud.size(), 0);
  if (n == 0) return valid;

  // PointCloud is contiguous xyz floats: FLANN indexes it in place.
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
  const flann::Matrix<float> points(const_cast<float*>(cloud.front().data()), cloud.size(), 3);
  flann::KDTreeSingleIndex<flann::L2_Simple<float>> tree(
      points, flann::KDTreeSingleIndexParams(/*leaf_max_size=*/15));
  tree.buildIndex();

  const double tan_tilt = std::tan(config.max_tilt_rad);
  const auto radius_sq = static_cast<float>(config.radius_m * config.radius_m);
  const flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED, /*eps=*/0.0f,
                                   /*sorted=*/false);
  num_threads = internal::ResolveThreadCount(num_threads);

#pragma omp parallel for schedule(dynamic, 1024) num_threads(num_threads)
  for (std::int64_t i = 0; i < n; ++i) {
    ElevationCheck check(cloud, cloud[i], radius_sq, tan_tilt, config.height_tolerance_m,
                         step_tolerance_m);
    tree.findNeighbors(check, cloud[i].data(), params);
    valid[i] = check.blocked() ? 0 : 1;
  }
  return valid;
}

}  // namespace strata
