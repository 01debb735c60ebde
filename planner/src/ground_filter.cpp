#include "strata/ground_filter.hpp"

#include <cmath>

#include <omp.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

namespace strata {

std::vector<std::uint8_t> FilterValidGround(const PointCloud& cloud,
                                            const GroundFilterConfig& config,
                                            int num_threads) {
  const auto n = static_cast<std::int64_t>(cloud.size());
  std::vector<std::uint8_t> valid(cloud.size(), 0);
  if (n == 0) return valid;

  auto pcl_cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl_cloud->resize(cloud.size());
  for (std::int64_t i = 0; i < n; ++i) {
    (*pcl_cloud)[i].getVector3fMap() = cloud[i];
  }
  // Unsorted results: the rule needs every neighbour, not the nearest first.
  pcl::KdTreeFLANN<pcl::PointXYZ> tree(/*sorted=*/false);
  tree.setInputCloud(pcl_cloud);

  // atan(dz / dxy) < θ  <=>  dz < tan(θ)·dxy for dz > 0, dxy >= 0 (θ < π/2), without atan.
  const double tan_tilt = std::tan(config.max_tilt_rad);
  const double tolerance = config.height_tolerance_m;
  const double radius = config.radius_m;
  if (num_threads <= 0) num_threads = omp_get_num_procs();

#pragma omp parallel num_threads(num_threads)
  {
    pcl::Indices neighbours;
    std::vector<float> sq_distances;
#pragma omp for schedule(dynamic, 256)
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = cloud[i];
      tree.radiusSearch((*pcl_cloud)[i], radius, neighbours, sq_distances);
      bool ok = true;
      for (const auto j : neighbours) {
        const Eigen::Vector3f& q = cloud[j];
        const double dz = double{q.z()} - p.z() - tolerance;
        if (dz <= 0.0) continue;  // Only what lies above p can block it.
        const double dxy = std::hypot(double{q.x()} - p.x(), double{q.y()} - p.y());
        if (!(dz < tan_tilt * dxy)) {
          ok = false;
          break;
        }
      }
      valid[i] = ok ? 1 : 0;
    }
  }
  return valid;
}

}  // namespace strata
