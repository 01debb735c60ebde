#pragma once
/// The point cloud type every stage of terrain assessment consumes.

#include <vector>

#include <Eigen/Core>

namespace strata {

/// Points in the map frame [m]. All finite once they leave the loader.
using PointCloud = std::vector<Eigen::Vector3f>;

/// The farthest from the origin, on any axis, that a map's points (CloudLoadLimits' default)
/// and a plan's start and goal may lie [m]: beyond it a coordinate is an error, not data.
inline constexpr double kMaxAbsCoordinateM = 1.0e5;

}  // namespace strata
