#pragma once
/// The benchmark's own check of a returned trajectory, written apart from VerifyTrajectory so
/// that "0 violations" is a finding, not a tautology. It shares with the planner only the map
/// (the column surfaces and the ESDF of the TerrainModel, by their plain queries), the robot
/// profile and the bounds VerifierConfig documents, copied in by the caller
/// (verifier_bounds.hpp); it includes none of the verifier's headers, and everything else is
/// its own:
/// - it evaluates the polynomials itself from the coefficient layout trajectory.hpp documents
///   (not Trajectory::EvaluatePiece);
/// - it samples by time (every time_step_s, for speed and acceleration) and by arc length
///   (every spacing_m, for the map), not by the verifier's speed-derived step;
/// - the ground under the robot is the highest surface of its own column at or below the
///   reference point (the paper's downward projection), with that surface's highest ground
///   point as its height, not SampleGround's smoothed plane fits nor the surface graph;
/// - keep-out zones by its own distance from a point to a polygon, not Prism's;
/// - it counts every sample that breaks each rule instead of stopping at the first.
#include <string>
#include <vector>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/prism.hpp"

namespace strata::bench {

/// The bounds a trajectory is held to, as VerifierConfig documents its fields of these names;
/// verifier_bounds.hpp copies them from one. No defaults here: the verifier's are the only
/// ones.
struct IndependentCheckBounds {
  double limit_tolerance;
  double ground_tolerance_m;
  double min_obstacle_distance_m;
};

struct IndependentCheckConfig {
  IndependentCheckBounds bounds;
  /// Arc length between the samples of the map rules (ground, clearance, headroom, keep-out)
  /// [m], > 0.
  double spacing_m = 0.01;
  /// Time between the samples of the motion rules (speed, acceleration, body height) [s], > 0.
  double time_step_s = 0.001;
  /// Zones the robot must stay out of (the map's and the request's), as keep_out.hpp defines
  /// it: the vertical cylinder of radius footprint_radius_m from the ground, z − reference
  /// height, up to that ground + max(highest body, reference height) must not reach into the
  /// polygon while their height ranges overlap by more than zero.
  std::vector<Prism> keep_out;
};

/// How many samples broke each rule (one sample may break several).
struct IndependentCheckCounts {
  int map_samples = 0;     ///< Samples of the map rules.
  int motion_samples = 0;  ///< Samples of the motion rules.
  /// No surface at or below the reference point in its column, or that surface is not valid
  /// ground, or steeper than the profile's max_tilt_rad, or z − reference height is off its
  /// ground by more than the ground tolerance plus r·√2·tan(max_tilt_rad) (the column's
  /// highest ground point may lie that far above the ground under the reference point on the
  /// steepest allowed slope, r the grid resolution).
  int ground = 0;
  int clearance = 0;  ///< ESDF distance at the reference point < min_obstacle_distance_m.
  /// Ceiling − body height < headroom_m − the body's tolerance: limit_tolerance × the highest
  /// body height (body_height_max_m, or body_height_m for a fixed height).
  int headroom = 0;
  int body_height = 0;   ///< Active height: outside [min, max] by more than that tolerance.
  int speed = 0;         ///< Horizontal or vertical speed above its bound × (1 + limit_tolerance).
  int acceleration = 0;  ///< Likewise for acceleration.
  int keep_out = 0;      ///< Inside a keep-out zone of the config.
  /// Whether any rule was broken.
  bool Any() const {
    return ground + clearance + headroom + body_height + speed + acceleration + keep_out > 0;
  }
  /// "ground 0, clearance 3, ...": the samples that broke each rule, for a failure message.
  std::string Describe() const;
};

/// Checks `trajectory` (dimension 3, or 4 with the body height for active-height profiles) on
/// `model` for `profile`. A trajectory with no pieces, a non-finite coefficient or a duration
/// that is not > 0 counts as one violation of every rule.
IndependentCheckCounts CheckTrajectory(const TerrainModel& model, const RobotProfile& profile,
                                       const Trajectory& trajectory,
                                       const IndependentCheckConfig& config);

/// Over a run: how many plans broke each rule at least once.
struct IndependentCheckTally {
  int plans = 0;  ///< Plans checked.
  int ground = 0, clearance = 0, headroom = 0, body_height = 0, speed = 0, acceleration = 0,
      keep_out = 0;
  void Add(const IndependentCheckCounts& counts);
  /// "1990 checked: ground 0, clearance 0, headroom 0, body height 0, speed 0, acceleration 0,
  /// keep-out 0".
  std::string Describe() const;
};

/// The CSV columns of one row's counts ("check_ground,...,check_keep_out") and their
/// values in that order; -1 in every column for a row that was not checked.
std::string IndependentCheckCsvHeader();
std::string IndependentCheckCsvValues(const IndependentCheckCounts* counts);

}  // namespace strata::bench
