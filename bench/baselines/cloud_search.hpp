#pragma once
// Neighbour queries on a point cloud (a pcl::KdTreeFLANN behind a small interface, so PCL's
// headers stay in one source file). Read-only after Build: queries are thread-safe.

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "strata/point_cloud.hpp"

namespace strata::baselines {

class CloudSearch {
 public:
  /// Indexes a copy of `cloud` (must not be empty).
  explicit CloudSearch(const PointCloud& cloud);
  ~CloudSearch();
  CloudSearch(const CloudSearch&) = delete;
  CloudSearch& operator=(const CloudSearch&) = delete;

  /// Indices of the points within radius_m of `center` (unordered) into *indices.
  void Radius(const Eigen::Vector3f& center, double radius_m, std::vector<int>* indices) const;
  /// Indices of the k nearest points, nearest first, and their squared distances [m²].
  void Nearest(const Eigen::Vector3f& center, int k, std::vector<int>* indices,
               std::vector<float>* squared_distances) const;

  const Eigen::Vector3f& point(int i) const { return points_[static_cast<std::size_t>(i)]; }
  const PointCloud& points() const { return points_; }
  std::size_t size() const { return points_.size(); }

  /// Median distance from a point to its nearest neighbour [m], over up to 2000 evenly
  /// spread points: the cloud's point spacing.
  double MedianSpacing() const;

 private:
  struct Impl;
  PointCloud points_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace strata::baselines
