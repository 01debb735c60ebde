#pragma once
/// The last gate before a plan is returned: the trajectory is checked against the map and the
/// robot's limits at every instant (exactly for its kinematics, by proofs between dense
/// samples for the map). A trajectory that fails is reported with its first violation, never
/// returned as success.
#include <span>
#include <string>
#include <string_view>

#include "strata/fleet/traffic.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/status.hpp"

namespace strata {

/// Verification settings. Validate() blames the first bad field by its path, `path`.<field>.
struct VerifierConfig {
  /// Largest distance between consecutive samples along the path [m], > 0.
  double max_sample_spacing_m = 0.02;
  /// Largest |z − (ground + reference height)| allowed [m], > 0. The ground is the smoothed
  /// plane-fit height (SampleGround); half a cell of slack covers the grid's quantisation.
  /// VerifyTrajectory raises it to 0.75 quanta on a voxelised cloud (ground known to ±q/2).
  double ground_tolerance_m = 0.1;
  /// Smallest ESDF distance at the reference point [m], >= 0 (the reference point is never
  /// inside an obstacle; walls are kept away by the ground filter radius).
  double min_obstacle_distance_m = 0.05;
  /// Speed and acceleration may exceed the profile's bounds by this fraction, >= 0. The body
  /// height may leave its range, and eat into the profile's headroom, by this fraction of the
  /// highest body height (BodyHeightTolerance: 7 mm for the built-in biped).
  double limit_tolerance = 0.01;
  Status Validate(std::string_view path = "verifier") const;
};

/// How far the body height may leave [body_height_min_m, body_height_max_m], and come closer
/// to the ceiling than the profile's headroom_m, in verification [m]: limit_tolerance × the
/// highest body height (body_height_max_m, or body_height_m for a fixed height).
double BodyHeightTolerance(const RobotProfile& profile, const VerifierConfig& config);

/// What verification measured (extremes: exact maxima of the kinematics, the map's figures
/// over the instants checked; filled even on failure up to the first violation).
struct VerificationReport {
  int samples = 0;
  double max_speed_horizontal_mps = 0;
  double max_speed_vertical_mps = 0;
  double max_accel_horizontal_mps2 = 0;
  double max_accel_vertical_mps2 = 0;
  double min_obstacle_distance_m = 0;
  double max_ground_offset_m = 0;
  double max_tilt_rad = 0;
  double min_body_height_m = 0;
  double min_headroom_m = 0;
};

/// Checks the trajectory at every instant, not only at samples (docs/design.md §13 says how
/// and what is proven): per piece, speed, acceleration and body height exactly (branch and
/// bound over Bernstein coefficients, polynomial_bounds.hpp); at samples at most
/// max_sample_spacing_m apart in 3D, at the first instant in every grid column the reference
/// point enters, and between them wherever a rule could change, proven over each stretch or
/// the stretch split and checked in its middle. The rules, in this order, failing with
/// kOptimizationFailed naming the first violation (time, position, the quantity, its value
/// and its bound), or a rule that cannot be shown over a stretch of 1e-9 s:
/// - horizontal and vertical speed and acceleration within the profile's bounds
///   (+ limit_tolerance), and the commanded body height within [body_height_min_m,
///   body_height_max_m] (within BodyHeightTolerance);
/// - the reference point inside the map's grid, over ground of its own column: the surface
///   SampleGround picks there (the one nearest to z − reference height, never another level
///   of the column), whose plane-fit height at the column's centre lies within the ground
///   tolerance (below) + (r/√2)·tan(max_tilt_rad) of z − reference height (r the grid
///   resolution; else the robot is inside a post, a leg or a wall, or cuts across a ledge
///   that the smoothed ground rounds off), which is valid ground with tilt <= max_tilt_rad;
/// - z within the ground tolerance of the smoothed ground of SampleGround + reference height:
///   ground_tolerance_m, or 0.75 quanta on a voxelised cloud if more;
/// - ESDF distance >= min_obstacle_distance_m;
/// - the surface's ceiling clearance at least the body height (commanded for active-height
///   robots, else body_height_m) + headroom_m, within BodyHeightTolerance;
/// - the surface is a node of `graph` (true when the graph was built from
///   profile.Traversability(), as Plan does);
/// - the robot outside every zone of `keep_out` (keep_out.hpp defines when it is inside;
///   the message names the zone and how far the footprint reaches into it);
/// then, when `traffic` is given, the trajectory placed at its departure and parked at its
/// end keeps apart from every other robot's motion, exactly over continuous time
/// (CheckSeparation: kReservationConflict naming the first robot in the way, when and where).
/// Every comparison fails on NaN. Fails before sampling with kInvalidConfig for a bad config
/// or profile, kInvalidInput when the trajectory's dimension is not the profile's (4 with
/// active height, else 3), and kOptimizationFailed for no pieces, a non-finite coefficient, a
/// duration that is not finite and > 0, or more than 2e7 samples.
Status VerifyTrajectory(const SurfaceGraph& graph, const RobotProfile& profile,
                        const Trajectory& trajectory, const VerifierConfig& config,
                        VerificationReport* report, std::span<const KeepOutZone> keep_out = {},
                        const Traffic* traffic = nullptr);

/// Mean curvature κ_m [1/m] (paper Table 2): the mean of ‖p′×p″‖/‖p′‖³ of the x, y, z path
/// over `samples` uniform time samples, skipping samples slower than 1 cm/s (where the
/// curvature of a stopping robot is undefined). 0 for an empty trajectory.
double MeanCurvature(const Trajectory& trajectory, int samples = 1000);

/// Arc length of the x, y, z path [m], by adaptive sampling (<= 1 cm of motion per step).
double PathLength(const Trajectory& trajectory);

}  // namespace strata
