#pragma once
// The figures of paper Table 2, computed the same way for every method: path length and mean
// curvature κ_m. Paths (the baselines' point paths) are interpolated by a centripetal
// Catmull-Rom spline and κ is averaged over uniform arc-length samples; trajectories (Strata)
// use strata::MeanCurvature (uniform time samples) and, for a like-for-like column, the same
// arc-length average evaluated on the trajectory's own derivatives.

#include <span>
#include <vector>

#include <Eigen/Core>

#include "statistics.hpp"
#include "strata/trajectory.hpp"

namespace strata::bench {

/// Sum of the segment lengths [m].
double PolylineLength(std::span<const Eigen::Vector3d> points);

/// κ_m of a point path [1/m]: consecutive points closer than 1 mm are merged; the remaining
/// points are joined by a centripetal Catmull-Rom spline (α = 0.5: no cusps or self-loops;
/// end points mirrored for the end tangents), each segment written as a cubic Hermite curve,
/// and ‖p′×p″‖/‖p′‖³ (exact for the cubic) is averaged over samples every `spacing_m` of arc
/// length (at the middles of equal arc-length intervals). 0 for fewer than 3 points.
double PathMeanCurvature(std::span<const Eigen::Vector3d> points, double spacing_m = 0.02);

/// κ_m of a trajectory over uniform arc-length samples every `spacing_m` [1/m], from its own
/// velocity and acceleration; samples slower than 1 cm/s are skipped (as MeanCurvature does).
double TrajectoryArcMeanCurvature(const Trajectory& trajectory, double spacing_m = 0.02);

/// Positions of the trajectory's x, y, z every `spacing_m` of arc length (and both ends).
std::vector<Eigen::Vector3d> SampleTrajectory(const Trajectory& trajectory, double spacing_m = 0.1);

}  // namespace strata::bench
