#pragma once
/// What a robot is, for planning: its size, the ground it may stand on, its speed and
/// acceleration limits and, for robots that can change their own height (a wheeled biped),
/// the range of body heights it can take.
///
/// Terrain parameters and maps: a map is assessed once (the Valid Ground Filter radius r and
/// steepest slope θ are part of its AssessmentConfig), and Strata does not reassess a map per
/// profile. A profile runs on a map when the map's assessment is at least as strict as the
/// profile needs: r_map >= footprint_radius_m (the filter has removed ground too close to
/// walls and overhangs for this footprint) and θ_map >= max_tilt_rad (the filter has not
/// removed ground the robot could use; the planner applies the profile's own θ on top).
/// Otherwise planning fails with kProfileMismatch naming both values: assess the map again
/// with the parameters the message gives. This keeps a map's memory bounded and its meaning
/// fixed; the server shows the parameters each map was assessed with.
#include <compare>
#include <concepts>
#include <numbers>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "strata/assessment/terrain_config.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

struct TraversabilityParams;

/// A start or goal state of the reference point (x, y, z). The planner snaps the position to
/// the ground; velocity and acceleration are used as given.
struct RobotState {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d acceleration_mps2 = Eigen::Vector3d::Zero();

  /// kInvalidInput blaming the first component that is not finite, or lies beyond
  /// kMaxAbsCoordinateM (position) or kMaxAbsMotion (velocity, acceleration), e.g.
  /// "start.position_m.x" for `path` "start".
  Status Validate(std::string_view path) const;

  /// The largest velocity [m/s] and acceleration [m/s^2] component a state may give.
  static constexpr double kMaxAbsMotion = 1.0e3;
};

struct RobotProfile {
  std::string name;  ///< Free text, for logs and reports.

  // Size and terrain.
  /// Radius of the circle that holds the robot's footprint [m], > 0. The map's ground filter
  /// radius must be at least this.
  double footprint_radius_m = 0.3;
  /// Steepest ground the robot may stand on [rad], in (0, π/2); at most the map's θ.
  double max_tilt_rad = 20.0 * std::numbers::pi / 180.0;
  /// Highest step (a curb, a riser) it can drive up [m], >= 0. Between neighbouring grid
  /// columns the ground may change by this plus the slope allowance (SurfaceGraph).
  double max_step_m = 0.15;
  /// Height of the trajectory's reference point above the ground [m], > 0: the z of the
  /// planned trajectory is ground height + this everywhere.
  double reference_height_m = 0.3;

  // Limits (the verifier holds the trajectory to them within 1%).
  double max_speed_horizontal_mps = 1.0;   ///< Bound on ‖(vx, vy)‖ [m/s], > 0.
  double max_speed_vertical_mps = 0.5;     ///< Bound on |vz| [m/s], > 0.
  double max_accel_horizontal_mps2 = 1.0;  ///< Bound on ‖(ax, ay)‖ [m/s²], > 0.
  double max_accel_vertical_mps2 = 0.5;    ///< Bound on |az| [m/s²], > 0.

  // Body height.
  /// False: the body height is fixed (body_height_m), passively carried by the terrain.
  /// True: the robot commands its body height in [body_height_min_m, body_height_max_m] and
  /// the trajectory gets a fourth dimension, the body height above ground.
  bool active_height = false;
  /// Passive: the body's height above ground [m]. Active: the preferred height [m], in
  /// [body_height_min_m, body_height_max_m]; the robot crouches below it only where the
  /// ceiling demands. In both cases > reference_height_m is not required, but > 0.
  double body_height_m = 0.5;
  double body_height_min_m = 0.5;  ///< Active only: lowest body height [m], > 0.
  double body_height_max_m = 0.5;  ///< Active only: highest body height [m], >= min.
  /// Free space kept between the top of the body and the ceiling [m], >= 0.
  double headroom_m = 0.05;

  /// The lowest the body can be [m]: body_height_min_m if active, else body_height_m. A
  /// place is traversable when its ceiling clearance is at least this plus headroom_m.
  double MinBodyHeight() const { return active_height ? body_height_min_m : body_height_m; }
  /// The highest the body can be [m]: body_height_max_m if active, else body_height_m.
  double MaxBodyHeight() const { return active_height ? body_height_max_m : body_height_m; }

  /// What the traversability graph needs from this profile: TraversabilityParams(*this).
  TraversabilityParams Traversability() const;

  /// kInvalidConfig blaming the first field out of range by its path, `path`.<field>.
  Status Validate(std::string_view path = "profile") const;
};

/// What a robot needs to stand somewhere: the part of a RobotProfile the traversability graph
/// (SurfaceGraph) depends on, derived from the profile (Plan never builds one otherwise).
/// PlanningMap caches one graph per distinct value, compared field by field (operator<=>), so
/// a field added here is part of the cache key without further work. Validate() blames the
/// first bad field by its path, `path`.<field>.
struct TraversabilityParams {
  /// The default RobotProfile's.
  TraversabilityParams() : TraversabilityParams(RobotProfile{}) {}
  explicit TraversabilityParams(const RobotProfile& profile)
      : reference_height_m(profile.reference_height_m),
        body_height_m(profile.MinBodyHeight() + profile.headroom_m),
        max_tilt_rad(profile.max_tilt_rad),
        max_step_m(profile.max_step_m) {}

  /// Height of the trajectory's reference point above the ground [m], in (0, body_height_m].
  double reference_height_m;
  /// Free height the body needs above the ground [m], > 0 and finite: the profile's lowest
  /// body height plus its headroom.
  double body_height_m;
  /// Steepest surface the robot stands on [rad], in (0, π/2); at most the map's ground
  /// filter θ (AssessmentConfig::ground.max_tilt_rad), since steeper ground is not valid.
  double max_tilt_rad;
  /// Highest step the robot climbs [m], >= 0, finite; neighbouring columns may differ by this
  /// plus the slope allowance (see SurfaceGraph).
  double max_step_m;

  Status Validate(std::string_view path = "traversability") const;
  // clang-tidy 14 mistakes the 0 a defaulted <=> compares with for a null pointer.
  auto operator<=>(const TraversabilityParams&) const = default;  // NOLINT(modernize-use-nullptr)
};

/// Calls visit(name, field) for every field of `params` (TraversabilityParams or const
/// TraversabilityParams): the one list of them that whatever stores them all follows (a saved
/// graph, the name of its file in a map store).
template <typename Params, typename Visit>
requires std::same_as<std::remove_const_t<Params>, TraversabilityParams>
void ForEachField(Params& params, Visit&& visit) {
  visit("reference_height_m", params.reference_height_m);
  visit("body_height_m", params.body_height_m);
  visit("max_tilt_rad", params.max_tilt_rad);
  visit("max_step_m", params.max_step_m);
}
static_assert(sizeof(TraversabilityParams) == 4 * sizeof(double),
              "a field added to TraversabilityParams belongs in its ForEachField");

/// Names of the built-in profiles, for help texts: "differential", "biped".
std::vector<std::string> BuiltinProfileNames();

/// A built-in profile by name:
/// - "differential": a four-wheeled differential-drive robot, 0.3 m footprint radius, body
///   0.5 m tall (passive height), reference point 0.3 m above ground, 1 m/s and 1 m/s²
///   horizontally, 0.5 m/s and 0.5 m/s² vertically, slopes up to 20°.
/// - "biped": a wheeled biped like the paper's Diablo, 0.3 m footprint radius, reference point
///   0.2 m above ground (wheel axles), body height 0.35–0.7 m (prefers 0.65), same limits,
///   slopes up to 15°.
/// Fails with kInvalidInput listing the known names.
Expected<RobotProfile> BuiltinProfile(const std::string& name);

/// Ok when `profile` can plan on a map assessed with `assessment` (see the file comment);
/// kProfileMismatch naming both values and the parameter to reassess with otherwise, blaming
/// "profile.footprint_radius_m" or "profile.max_tilt_rad".
Status CheckProfileFitsMap(const RobotProfile& profile, const AssessmentConfig& assessment);

}  // namespace strata
