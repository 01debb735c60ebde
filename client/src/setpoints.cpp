#include "strata/client/setpoints.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "strata/v1/planner_service.pb.h"

namespace strata::client {
namespace {

constexpr double kBisectionTolerance_s = 1e-9;

std::string Number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", value);
  return buffer;
}

double HorizontalSpeed(const PolynomialTrajectory& trajectory, double t_s) {
  const Eigen::VectorXd v = trajectory.Evaluate(t_s, 1);
  return std::hypot(v[0], v[1]);
}

double Heading(const PolynomialTrajectory& trajectory, double t_s) {
  const Eigen::VectorXd v = trajectory.Evaluate(t_s, 1);
  return std::atan2(v[1], v[0]);
}

// Narrows [fast, slow] (either order) to the threshold crossing; returns the heading on the
// fast side, the last (or first) well-defined direction of motion.
double HeadingAtCrossing(const PolynomialTrajectory& trajectory, double fast_s, double slow_s,
                         double min_speed_mps) {
  for (int i = 0; i < 64 && std::abs(fast_s - slow_s) > kBisectionTolerance_s; ++i) {
    const double mid_s = 0.5 * (fast_s + slow_s);
    (HorizontalSpeed(trajectory, mid_s) >= min_speed_mps ? fast_s : slow_s) = mid_s;
  }
  return Heading(trajectory, fast_s);
}

// The yaw to hold at t_s, where the speed is below the threshold: the heading the robot had
// when it last moved, else the one it will first move with; nullopt if it never moves.
std::optional<double> HeldYaw(const PolynomialTrajectory& trajectory, double t_s,
                              const SetpointOptions& options) {
  const double min_speed = options.min_speed_for_yaw_mps;
  const double step_s = options.yaw_search_step_s;
  const double end_s = trajectory.duration_s();

  // Backwards from t (or from the end, past it) to 0. The trajectory's own speed at its end
  // counts: a goal with a velocity keeps that velocity's heading past the end.
  if (t_s >= 0) {
    const double from_s = std::min(t_s, end_s);
    if (HorizontalSpeed(trajectory, from_s) >= min_speed) return Heading(trajectory, from_s);
    double slow_s = from_s;
    for (long k = 1; slow_s > 0; ++k) {
      const double tau_s = std::max(0.0, from_s - static_cast<double>(k) * step_s);
      if (HorizontalSpeed(trajectory, tau_s) >= min_speed) {
        return HeadingAtCrossing(trajectory, tau_s, slow_s, min_speed);
      }
      slow_s = tau_s;
    }
  }
  // Not moved yet: forwards to the first motion.
  const double from_s = std::max(t_s, 0.0);
  double slow_s = from_s;
  for (long k = 1; slow_s < end_s; ++k) {
    const double tau_s = std::min(end_s, from_s + static_cast<double>(k) * step_s);
    if (HorizontalSpeed(trajectory, tau_s) >= min_speed) {
      return HeadingAtCrossing(trajectory, tau_s, slow_s, min_speed);
    }
    slow_s = tau_s;
  }
  return std::nullopt;
}

// Wraps an angle to (−π, π].
double WrapAngle(double angle_rad) {
  const double two_pi = 2 * std::numbers::pi;
  double wrapped = std::remainder(angle_rad, two_pi);  // In [−π, π].
  if (wrapped <= -std::numbers::pi) wrapped += two_pi;
  return wrapped;
}

}  // namespace

std::optional<ClientError> SetpointOptions::Validate() const {
  if (!std::isfinite(min_speed_for_yaw_mps) || min_speed_for_yaw_mps <= 0) {
    return ClientError{"min_speed_for_yaw_mps is " + Number(min_speed_for_yaw_mps) +
                       " m/s; it must be > 0 and finite"};
  }
  if (!std::isfinite(yaw_search_step_s) || yaw_search_step_s <= 0) {
    return ClientError{"yaw_search_step_s is " + Number(yaw_search_step_s) +
                       " s; it must be > 0 and finite"};
  }
  return std::nullopt;
}

MpcSetpoint SetpointAt(const PolynomialTrajectory& trajectory, double t_s,
                       const SetpointOptions& options) {
  MpcSetpoint setpoint;
  setpoint.time_s = t_s;
  const Eigen::VectorXd position = trajectory.Evaluate(t_s, 0);
  const Eigen::VectorXd velocity = trajectory.Evaluate(t_s, 1);
  const Eigen::VectorXd acceleration = trajectory.Evaluate(t_s, 2);
  setpoint.position_m = position.head<3>();
  setpoint.velocity_mps = velocity.head<3>();
  setpoint.acceleration_mps2 = acceleration.head<3>();
  if (trajectory.dimension() == 4) setpoint.body_height_m = position[3];

  const double vx = velocity[0], vy = velocity[1];
  setpoint.speed_mps = std::hypot(vx, vy);
  if (setpoint.speed_mps >= options.min_speed_for_yaw_mps) {
    setpoint.yaw_rad = WrapAngle(std::atan2(vy, vx));
    setpoint.yaw_rate_radps = (vx * acceleration[1] - vy * acceleration[0]) / (vx * vx + vy * vy);
  } else {
    setpoint.yaw_held = true;
    setpoint.yaw_rad = WrapAngle(HeldYaw(trajectory, t_s, options).value_or(0.0));
    setpoint.yaw_rate_radps = 0;
  }
  return setpoint;
}

Expected<std::vector<MpcSetpoint>> ComputeSetpoints(const PolynomialTrajectory& trajectory,
                                                    double t0_s, double dt_s, int steps,
                                                    const SetpointOptions& options) {
  if (auto error = options.Validate()) return *error;
  if (!std::isfinite(t0_s)) return ClientError{"t0_s is " + Number(t0_s) + "; it must be finite"};
  if (!std::isfinite(dt_s) || dt_s <= 0) {
    return ClientError{"dt_s is " + Number(dt_s) + " s; it must be > 0 and finite"};
  }
  constexpr int kMaxSteps = 1000000;
  if (steps < 1 || steps > kMaxSteps) {
    return ClientError{"steps is " + std::to_string(steps) + "; it must be in [1, " +
                       std::to_string(kMaxSteps) + "]"};
  }
  std::vector<MpcSetpoint> setpoints;
  setpoints.reserve(static_cast<std::size_t>(steps));
  for (int k = 0; k < steps; ++k) {
    MpcSetpoint setpoint = SetpointAt(trajectory, t0_s + k * dt_s, options);
    if (options.unwrap_yaw && k > 0) {
      const double previous = setpoints.back().yaw_rad;
      setpoint.yaw_rad = previous + WrapAngle(setpoint.yaw_rad - previous);
    }
    setpoints.push_back(std::move(setpoint));
  }
  return setpoints;
}

Expected<std::vector<MpcSetpoint>> ComputeSetpointsAt(const PolynomialTrajectory& trajectory,
                                                      std::chrono::system_clock::time_point start,
                                                      std::chrono::system_clock::time_point from,
                                                      double dt_s, int steps,
                                                      const SetpointOptions& options) {
  const double t0_s = std::chrono::duration<double>(from - start).count();
  return ComputeSetpoints(trajectory, t0_s, dt_s, steps, options);
}

std::optional<std::chrono::system_clock::time_point> DepartureOf(const v1::PlanResponse& response) {
  if (!response.has_departure_time()) return std::nullopt;
  const auto& time = response.departure_time();
  return std::chrono::system_clock::time_point(
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::seconds(time.seconds()) + std::chrono::nanoseconds(time.nanos())));
}

}  // namespace strata::client
