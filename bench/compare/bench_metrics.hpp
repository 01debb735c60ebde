#pragma once
// The figures of paper Table 2, computed the same way for every method: path length and mean
// curvature κ_m, averaged over uniform arc-length samples of the curve, with no sample dropped
// for being slow (only an exactly stationary one, where κ is undefined). Paths (the
// baselines' point paths) are interpolated by a centripetal Catmull-Rom spline; trajectories
// (Strata) use their own derivatives. κ is taken either in 3D or on the x–y projection: the
// baselines' paths join raw cloud points, whose few millimetres of height noise make most of
// a 3D curvature on jittered scenes, while the projection measures how the path turns.

#include <span>
#include <vector>

#include <Eigen/Core>

#include "statistics.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata::bench {

/// Sum of the segment lengths [m].
double PolylineLength(std::span<const Eigen::Vector3d> points);

/// Where curvature is measured: along the 3D curve, or along its projection on the x–y plane
/// (positions and derivatives with z dropped; arc length then the projection's).
enum class CurvatureSpace { k3d, kPlanar };

/// κ_m of a point path [1/m]: consecutive points closer than 1 mm (in `space`) are merged; the
/// remaining points are joined by a centripetal Catmull-Rom spline (α = 0.5: no cusps or
/// self-loops; end points mirrored for the end tangents), each segment written as a cubic
/// Hermite curve, and ‖p′×p″‖/‖p′‖³ (exact for the cubic) is averaged over samples every
/// `spacing_m` of arc length (at the middles of equal arc-length intervals). 0 for fewer than
/// 3 points.
double PathMeanCurvature(std::span<const Eigen::Vector3d> points, CurvatureSpace space,
                         double spacing_m = 0.02);

/// κ_m of a trajectory [1/m], averaged as PathMeanCurvature does, from the trajectory's own
/// velocity and acceleration.
double TrajectoryMeanCurvature(const Trajectory& trajectory, CurvatureSpace space,
                               double spacing_m = 0.02);

/// Positions of the trajectory's x, y, z every `spacing_m` of arc length (and both ends).
std::vector<Eigen::Vector3d> SampleTrajectory(const Trajectory& trajectory, double spacing_m = 0.1);

}  // namespace strata::bench
