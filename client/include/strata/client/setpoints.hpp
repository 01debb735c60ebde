#pragma once
/// MPC setpoints from a trajectory: what a ground robot's tracking controller consumes.
///
/// At global time τ (clamped as PolynomialTrajectory documents) with velocity (vx, vy, vz) and
/// acceleration (ax, ay, az):
///   - position x, y, z [m] and, for dimension-4 trajectories, the body height [m];
///   - speed v = ‖(vx, vy)‖ [m/s], the horizontal speed (the one the robot profile bounds);
///   - yaw ψ = atan2(vy, vx) [rad], the direction of horizontal motion, counter-clockwise
///     from the map's +x axis about +z;
///   - yaw rate ω = dψ/dt = (vx·ay − vy·ax) / (vx² + vy²) [rad/s], exact (not differenced),
///     positive counter-clockwise (turning left).
/// Below `min_speed_for_yaw_mps` the direction of motion is not well defined (it is noise at
/// a stop). There the yaw is *held*: it is the heading at the last time before τ when the
/// speed was at least the threshold (so the robot keeps the heading it stopped with, and
/// past the end it keeps the final heading); if the robot has not moved yet (at the start,
/// or before τ = 0) it is the first direction of motion after τ instead, so the robot turns
/// towards where it will go. ω is 0 where the yaw is held. A trajectory that never reaches
/// the threshold has yaw 0 everywhere, with `yaw_held` set.
#include <chrono>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "strata/client/expected.hpp"
#include "strata/client/polynomial_trajectory.hpp"

namespace strata::client {

/// How setpoints are derived; the defaults suit ground robots.
struct SetpointOptions {
  /// Horizontal speed below which the yaw is held instead of taken from the velocity [m/s],
  /// > 0 and finite. Default 1 mm/s.
  double min_speed_for_yaw_mps = 1e-3;
  /// Step of the search for the time where the speed crosses the threshold, when the yaw
  /// must be held [s], > 0 and finite. The crossing is then refined by bisection to 1 ns,
  /// so this only bounds how short a motion the search can miss. Default 0.01 s.
  double yaw_search_step_s = 0.01;
  /// True: over a horizon, each yaw is unwrapped to within π of the previous one (the yaw is
  /// continuous; the first is in (−π, π]). False: every yaw is in (−π, π].
  bool unwrap_yaw = true;

  /// The first field out of its range, named with its value; nullopt when all are valid.
  std::optional<ClientError> Validate() const;
};

/// One MPC setpoint.
struct MpcSetpoint {
  double time_s = 0;  ///< Global time [s], as asked for (clamping applies to the values).
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();         ///< x, y, z [m].
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();       ///< [m/s].
  Eigen::Vector3d acceleration_mps2 = Eigen::Vector3d::Zero();  ///< [m/s²].
  double speed_mps = 0;       ///< Horizontal speed ‖(vx, vy)‖ [m/s], >= 0.
  double yaw_rad = 0;         ///< Heading of horizontal motion [rad]; see the file comment.
  double yaw_rate_radps = 0;  ///< dψ/dt [rad/s], counter-clockwise positive; 0 when held.
  bool yaw_held = false;      ///< True when the speed is below the threshold (yaw held).
  std::optional<double> body_height_m;  ///< Commanded body height [m]; dimension 4 only.
};

/// The setpoint at global time `t_s`, yaw in (−π, π]. Preconditions: `options` valid,
/// `t_s` finite.
MpcSetpoint SetpointAt(const PolynomialTrajectory& trajectory, double t_s,
                       const SetpointOptions& options = {});

/// `steps` setpoints at t0_s + k·dt_s, k = 0 … steps − 1. Fails naming the argument unless
/// t0_s is finite, dt_s > 0 and finite, steps in [1, 1000000], and `options` is valid.
Expected<std::vector<MpcSetpoint>> ComputeSetpoints(const PolynomialTrajectory& trajectory,
                                                    double t0_s, double dt_s, int steps,
                                                    const SetpointOptions& options = {});

/// The same horizon on the wall clock, for a trajectory that starts at absolute time
/// `start` (a fleet plan's PlanResponse.departure_time, see DepartureOf): `steps` setpoints at
/// `from` + k·dt_s. Before `start` the robot holds the trajectory's first state (it waits for
/// its departure); the times in the setpoints are on the trajectory's clock (from − start).
/// Fails as ComputeSetpoints.
Expected<std::vector<MpcSetpoint>> ComputeSetpointsAt(const PolynomialTrajectory& trajectory,
                                                      std::chrono::system_clock::time_point start,
                                                      std::chrono::system_clock::time_point from,
                                                      double dt_s, int steps,
                                                      const SetpointOptions& options = {});

/// When a plan's trajectory starts on the wall clock: its departure_time (a fleet plan's), or
/// nullopt for a plan without one (its t = 0 is whenever the robot starts it).
std::optional<std::chrono::system_clock::time_point> DepartureOf(const v1::PlanResponse& response);

}  // namespace strata::client
