#include "baselines/cloud_search.hpp"

#include <algorithm>
#include <cmath>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

namespace strata::baselines {

struct CloudSearch::Impl {
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
};

CloudSearch::CloudSearch(const PointCloud& cloud)
    : points_(cloud), impl_(std::make_unique<Impl>()) {
  auto pcl_cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl_cloud->resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    (*pcl_cloud)[i] = pcl::PointXYZ(cloud[i].x(), cloud[i].y(), cloud[i].z());
  }
  impl_->tree.setSortedResults(false);
  impl_->tree.setInputCloud(pcl_cloud);
}

CloudSearch::~CloudSearch() = default;

void CloudSearch::Radius(const Eigen::Vector3f& center, double radius_m,
                         std::vector<int>* indices) const {
  thread_local std::vector<float> squared;
  indices->clear();
  impl_->tree.radiusSearch(pcl::PointXYZ(center.x(), center.y(), center.z()), radius_m, *indices,
                           squared);
}

void CloudSearch::Nearest(const Eigen::Vector3f& center, int k, std::vector<int>* indices,
                          std::vector<float>* squared_distances) const {
  indices->assign(static_cast<std::size_t>(k), 0);
  squared_distances->assign(static_cast<std::size_t>(k), 0.f);
  const int found = impl_->tree.nearestKSearch(pcl::PointXYZ(center.x(), center.y(), center.z()), k,
                                               *indices, *squared_distances);
  indices->resize(static_cast<std::size_t>(std::max(found, 0)));
  squared_distances->resize(indices->size());
}

double CloudSearch::MedianSpacing() const {
  if (points_.size() < 2) return 0;
  const std::size_t stride = std::max<std::size_t>(1, points_.size() / 2000);
  std::vector<double> nearest;
  std::vector<int> indices;
  std::vector<float> squared;
  for (std::size_t i = 0; i < points_.size(); i += stride) {
    Nearest(points_[i], 2, &indices, &squared);
    if (squared.size() == 2) nearest.push_back(std::sqrt(static_cast<double>(squared[1])));
  }
  if (nearest.empty()) return 0;
  std::nth_element(nearest.begin(), nearest.begin() + static_cast<long>(nearest.size() / 2),
                   nearest.end());
  return nearest[nearest.size() / 2];
}

}  // namespace strata::baselines
