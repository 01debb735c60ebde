#pragma once
// The one footprint test both baselines apply where the robot would stand: ground under the
// whole footprint disc and no points in the body's column above it.

#include <span>

#include <Eigen/Core>

#include "baselines/baseline_robot.hpp"

namespace strata::baselines {

/// What CheckFootprint found.
struct FootprintVerdict {
  bool supported = false;  ///< Ground within a step of the plane in all eight sectors.
  bool body_free = false;  ///< No point in the body column (above a step, below clearance).
  bool ok() const { return supported && body_free; }
};

/// Tests a robot standing at `ground_m` on the local plane with upward unit normal
/// `normal` (normal.z() > 0) against `neighbours` (cloud points near ground_m; extra points
/// are ignored). A point q inside the disc of radius `support_radius_m` (>= the footprint
/// radius; see the baselines' README for voxelised clouds) at height h above the plane,
/// measured vertically: |h| <= max_step_m is ground, and the footprint is supported when
/// each of the eight 45° sectors of the annulus from 60% to 100% of the support radius holds
/// such a point (so the robot's centre is at least ~55% of the radius from any edge: at most
/// a sliver of the footprint overhangs); max_step_m < h <= clearance_m inside the footprint
/// radius blocks the body.
FootprintVerdict CheckFootprint(const Eigen::Vector3f& ground_m, const Eigen::Vector3f& normal,
                                std::span<const Eigen::Vector3f> neighbours,
                                const BaselineRobot& robot, double support_radius_m);

/// Half-extent of the sphere around ground_m + (0, 0, CheckFootprintCenterLift) that holds
/// every point CheckFootprint can use, for ground up to robot.max_tilt_rad [m].
double CheckFootprintQueryRadius(const BaselineRobot& robot, double support_radius_m);
/// Height above ground_m of that sphere's centre [m].
double CheckFootprintCenterLift(const BaselineRobot& robot, double support_radius_m);

}  // namespace strata::baselines
