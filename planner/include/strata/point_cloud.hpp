#pragma once
/// The point cloud type every stage of terrain assessment consumes.

#include <vector>

#include <Eigen/Core>

namespace strata {

/// Points in the map frame [m]. All finite once they leave the loader.
using PointCloud = std::vector<Eigen::Vector3f>;

}  // namespace strata
