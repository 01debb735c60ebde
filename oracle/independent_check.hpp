#pragma once
/// The benchmark's own check of a returned trajectory, written apart from VerifyTrajectory so
/// that "0 violations" is a finding, not a tautology. It shares with the planner only the map
/// (the column surfaces and the ESDF of the TerrainModel), the robot profile and the bounds
/// VerifierConfig documents (BodyHeightTolerance included); everything else is its own:
/// - it evaluates the polynomials itself from the coefficient layout trajectory.hpp documents
///   (not Trajectory::EvaluatePiece);
/// - it samples by time (every time_step_s, for speed and acceleration) and by arc length
///   (every spacing_m, for the map), not by the verifier's speed-derived step;
/// - the ground under the robot is the highest surface of its own column at or below the
///   reference point (the paper's downward projection), with that surface's highest ground
///   point as its height, not SampleGround's smoothed plane fits nor the surface graph;
/// - it counts every sample that breaks each rule instead of stopping at the first.
#include <string>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/verification/trajectory_verifier.hpp"

namespace strata::bench {

struct IndependentCheckConfig {
  /// Arc length between the samples of the map rules (ground, clearance, headroom) [m], > 0.
  double spacing_m = 0.01;
  /// Time between the samples of the motion rules (speed, acceleration, body height) [s], > 0.
  double time_step_s = 0.001;
  /// The bounds: limit_tolerance, ground_tolerance_m and min_obstacle_distance_m, read as
  /// VerifierConfig documents them.
  VerifierConfig bounds;
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
  int clearance = 0;     ///< ESDF distance at the reference point < min_obstacle_distance_m.
  int headroom = 0;      ///< Ceiling − body height < headroom_m − BodyHeightTolerance.
  int body_height = 0;   ///< Active height: outside [min, max] by more than BodyHeightTolerance.
  int speed = 0;         ///< Horizontal or vertical speed above its bound × (1 + limit_tolerance).
  int acceleration = 0;  ///< Likewise for acceleration.
  /// Whether any rule was broken.
  bool Any() const {
    return ground + clearance + headroom + body_height + speed + acceleration > 0;
  }
  /// "ground 0, clearance 3, ...": the samples that broke each rule, for a failure message.
  std::string Describe() const;
};

/// Checks `trajectory` (dimension 3, or 4 with the body height for active-height profiles) on
/// `model` for `profile`. A trajectory with no pieces, a non-finite coefficient or a duration
/// that is not > 0 counts as one violation of every rule.
IndependentCheckCounts CheckTrajectory(const TerrainModel& model, const RobotProfile& profile,
                                       const Trajectory& trajectory,
                                       const IndependentCheckConfig& config = {});

/// Over a run: how many plans broke each rule at least once.
struct IndependentCheckTally {
  int plans = 0;  ///< Plans checked.
  int ground = 0, clearance = 0, headroom = 0, body_height = 0, speed = 0, acceleration = 0;
  void Add(const IndependentCheckCounts& counts);
  /// "1990 checked: ground 0, clearance 0, headroom 0, body height 0, speed 0, acceleration 0".
  std::string Describe() const;
};

/// The CSV columns of one row's counts ("check_ground,...,check_acceleration") and their
/// values in that order; -1 in every column for a row that was not checked.
std::string IndependentCheckCsvHeader();
std::string IndependentCheckCsvValues(const IndependentCheckCounts* counts);

}  // namespace strata::bench
