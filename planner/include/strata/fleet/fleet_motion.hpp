#pragma once
/// A robot's committed motion on a shared site: a trajectory placed at an absolute time, the
/// body it moves, and how long it then stays parked at its end. Fleet planning keeps the
/// motions of other robots apart from each other (strata/fleet/motion_conflict.hpp).
///
/// Time: absolute times are nanoseconds since the Unix epoch on the server's clock (robots and
/// servers keep NTP time). The motion exists over [start_ns, end_ns]: it follows the
/// trajectory from start_ns, then holds the trajectory's last position until end_ns.
#include <cstdint>
#include <string_view>

#include <Eigen/Core>

#include "strata/planning/trajectory.hpp"
#include "strata/status.hpp"

namespace strata {

struct RobotProfile;

/// The space a robot occupies around its trajectory's reference point: a vertical cylinder
/// of radius radius_m from the ground under the reference point to the top of the body.
struct FleetBody {
  double radius_m = 0.3;            ///< Footprint radius [m], > 0 and finite.
  double reference_height_m = 0.3;  ///< Reference point above the ground [m], > 0, finite.
  /// Top of the body above the ground [m], > 0, finite, for trajectories of dimension 3. A
  /// trajectory of dimension 4 commands its body height on axis 3, which is used instead.
  double height_m = 0.5;

  /// The body of a robot with this profile: its footprint radius, reference height, and body
  /// height (the highest it can take for an active-height robot, which a 3-D trajectory
  /// cannot tell).
  static FleetBody FromProfile(const RobotProfile& profile);

  /// kInvalidInput blaming the first bad field, `path`.<field>.
  Status Validate(std::string_view path) const;
};

/// The vertical extent of a body at one moment [m, map frame]: from the ground to its top.
struct VerticalExtent {
  double bottom_m = 0;
  double top_m = 0;
};

struct FleetMotion {
  std::int64_t start_ns = 0;  ///< Absolute time of the trajectory's t = 0 [ns].
  Trajectory trajectory;      ///< At least one piece; dimension 3 or 4.
  FleetBody body;
  /// Absolute time until which the robot stays parked at the trajectory's end [ns], at least
  /// start_ns + the trajectory's duration.
  std::int64_t end_ns = 0;
  /// The free distance this robot asks every other to keep from its body [m], >= 0, finite:
  /// its plan's separation (SeparationRule::separation_m; Traffic::MotionOf sets it). Two
  /// motions keep the larger of their two and the check's rule's (PairSeparationM).
  double separation_m = 0;

  /// When the trajectory ends and the parked time begins [ns].
  std::int64_t ArrivalNs() const;

  /// The trajectory's state (x, y, z[, body height]) at absolute time `time_ns`, clamped to
  /// [start_ns, end_ns]: before the start its first point, after the arrival its last.
  StateVector StateAt(std::int64_t time_ns) const;
  /// The time into the trajectory [s] at which StateAt(time_ns) evaluates it.
  double TrajectoryTimeAt(std::int64_t time_ns) const;
  /// The reference point at absolute time `time_ns`, clamped as StateAt.
  Eigen::Vector3d ReferencePointAt(std::int64_t time_ns) const;
  /// The body's vertical extent at absolute time `time_ns`, clamped as ReferencePointAt.
  VerticalExtent ExtentAt(std::int64_t time_ns) const;
  /// The body's vertical extent where the trajectory's state is `state`.
  VerticalExtent ExtentOf(const StateVector& state) const;

  /// kInvalidInput blaming the first bad field, `path`.<field>: a dimension other than 3 or 4,
  /// pieces Trajectory::ValidatePieces refuses (at most kMaxTrajectoryPieces), a bad body,
  /// end_ns before the arrival, or a separation that is negative or not finite.
  Status Validate(std::string_view path) const;
};

/// The motion of a robot that keeps to its committed `current` motion until `next` departs,
/// then follows `next`: how a new plan replaces a robot's reservation from its departure on.
/// `current`'s pieces up to next.start_ns (the last one cut there; parked at its end when it
/// arrives sooner), then `next`'s, with `next`'s body, until next.end_ns. Pieces of `current`
/// that end by `now_ns` are left out, as the past holds nobody up. `next` itself when it
/// departs by `now_ns` or by the time `current` starts, or when the two differ in dimension
/// (a robot that changed its profile).
FleetMotion ContinuedBy(const FleetMotion& current, const FleetMotion& next, std::int64_t now_ns);

/// A piece of `duration_s` [s] at rest at `state` (x, y, z[, body height]).
TrajectoryPiece RestAt(const StateVector& state, double duration_s);

/// Seconds between two absolute times (to - from) [s]. Differences of at most centuries are
/// exact to well under a microsecond.
double SecondsBetween(std::int64_t from_ns, std::int64_t to_ns);
/// `time_ns` moved by `seconds` [s], rounded to the nanosecond.
std::int64_t AddSeconds(std::int64_t time_ns, double seconds);

}  // namespace strata
