#pragma once
/// Valid Ground Filter (paper Sec. III, eq. 1, Alg. 1, Fig. 2; docs/design.md §3).

#include <cstdint>
#include <vector>

#include "strata/assessment/terrain_config.hpp"
#include "strata/point_cloud.hpp"

namespace strata {

/// Marks the points a robot can stand on. A point p is valid when every neighbour q within
/// distance `radius_m` of p that lies above p does so at an elevation angle
/// atan((q_z − p_z) / ‖q_xy − p_xy‖) below `max_tilt_rad`: nothing overhead within r (the
/// paper's point D), no wall beside it (B), no slope steeper than θ rising from it (C).
/// With config.height_tolerance_m = ε > 0 the test is atan((q_z − p_z − ε) / ‖q_xy − p_xy‖) < θ
/// for neighbours with q_z − p_z > ε, so millimetre noise on flat ground does not count.
///
/// This is the rule the paper's text and figure describe. Eq. 1 as printed computes the angle
/// as atan((p_z − q_z)/…), which is negative for the neighbours above it is meant to test, and
/// Alg. 1 as printed tests the neighbours below and adds p on the first one that passes; both
/// are slips, so neither is followed literally.
///
/// Neighbours are found by scanning the points of the grid columns around p, each column sorted
/// by height (so only the slice above p within r is read), in parallel with `num_threads`
/// threads (0 = every core): O(N) for N points at a bounded density, duplicates included.
/// Returns one flag per point (1 = valid ground).
/// `step_tolerance_m` > 0 (the height step of a voxelised cloud) lets a neighbour at most that
/// much higher and at least half of it away horizontally pass as a step, not an obstacle.
/// Precondition: config.Validate() is ok and every point is finite.
std::vector<std::uint8_t> FilterValidGround(const PointCloud& cloud,
                                            const GroundFilterConfig& config, int num_threads = 0,
                                            double step_tolerance_m = 0);

}  // namespace strata
