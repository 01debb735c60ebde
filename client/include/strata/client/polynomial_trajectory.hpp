#pragma once
/// A trajectory from a Plan response, evaluated exactly on the robot (no map, no planner).
///
/// Definition (proto/strata/v1/trajectory.proto): frame "map", metres and seconds. Piece i
/// lasts T_i and covers global time [S_i, S_i + T_i] with S_i = Σ_{k<i} T_k; at global time τ
/// its local time is t = τ − S_i and axis a is at
///   p_{i,a}(t) = Σ_{k=0..5} c_{i,a,k} · t^k          (lowest order first).
/// Derivatives are the polynomials' exact derivatives, evaluated by Horner's rule. Axes 0, 1, 2
/// are x, y, z of the reference point; a dimension-4 trajectory adds axis 3, the commanded
/// body height above the ground [m].
///
/// Time outside [0, duration_s()] is clamped:
///   - τ < 0: the start state, i.e. every derivative as at τ = 0 (position, and the start's
///     velocity, acceleration and jerk, normally zero velocity and acceleration);
///   - τ > duration_s(): the final position (and body height) with zero velocity,
///     acceleration and jerk: the robot holds the goal once the trajectory is over.
/// τ = duration_s() itself evaluates the last piece at its end.
#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "strata/client/expected.hpp"

namespace strata::v1 {
class Trajectory;
class PlanResponse;
}  // namespace strata::v1

namespace strata::client {

/// Every quantity of a trajectory at one time.
struct TrajectoryState {
  double time_s = 0;  ///< Global time asked for [s] (before clamping).
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();         ///< Reference point [m].
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();       ///< [m/s].
  Eigen::Vector3d acceleration_mps2 = Eigen::Vector3d::Zero();  ///< [m/s²].
  Eigen::Vector3d jerk_mps3 = Eigen::Vector3d::Zero();          ///< [m/s³].
  std::optional<double> body_height_m;         ///< Axis 3 [m]; set only for dimension 4.
  std::optional<double> body_height_rate_mps;  ///< d(axis 3)/dt [m/s]; dimension 4 only.
};

/// A validated piecewise-quintic trajectory. Immutable; cheap to evaluate (a binary search
/// for the piece, then Horner's rule on 6 coefficients per axis).
class PolynomialTrajectory {
 public:
  static constexpr int kCoefficientsPerAxis = 6;  ///< Quintic: c_0 … c_5.
  static constexpr int kMaxOrder = 5;             ///< Highest non-zero derivative.

  /// Builds from the proto. Fails, naming the field and value, unless: dimension is 3 or 4;
  /// there is at least one piece; every piece has `dimension` axes of exactly 6 finite
  /// coefficients and a duration that is > 0 and finite; and `duration_s`, when non-zero,
  /// equals the sum of the pieces' durations (relative tolerance 1e-9).
  static Expected<PolynomialTrajectory> FromProto(const v1::Trajectory& trajectory);
  /// FromProto(response.trajectory()); fails as well when the response has no trajectory.
  static Expected<PolynomialTrajectory> FromPlanResponse(const v1::PlanResponse& response);

  /// 3 (x, y, z) or 4 (x, y, z, body height).
  int dimension() const { return dimension_; }
  std::size_t piece_count() const { return pieces_.size(); }
  /// Total duration Σ T_i [s], > 0.
  double duration_s() const { return duration_s_; }
  /// Global start time S_i of piece i [s]; precondition: i < piece_count().
  double piece_start_s(std::size_t i) const { return pieces_[i].start_s; }
  /// Duration T_i of piece i [s]; precondition: i < piece_count().
  double piece_duration_s(std::size_t i) const { return pieces_[i].duration_s; }

  /// The `order`-th time derivative (0 = position … 5; higher orders are zero) of every
  /// axis at global time `t_s` [s], with the clamping described above. Units: m/s^order.
  /// A NaN time gives NaN values.
  Eigen::VectorXd Evaluate(double t_s, int order) const;
  /// The `order`-th derivative of piece `piece` at local time `t_s` ∈ [0, T_piece], without
  /// clamping (a plain polynomial evaluation). Precondition: piece < piece_count().
  Eigen::VectorXd EvaluatePiece(std::size_t piece, double t_s, int order) const;

  /// Position, velocity, acceleration, jerk (and body height) at `t_s`, clamped as above.
  TrajectoryState StateAt(double t_s) const;
  Eigen::Vector3d PositionAt(double t_s) const { return Evaluate(t_s, 0).head<3>(); }
  Eigen::Vector3d VelocityAt(double t_s) const { return Evaluate(t_s, 1).head<3>(); }
  Eigen::Vector3d AccelerationAt(double t_s) const { return Evaluate(t_s, 2).head<3>(); }
  Eigen::Vector3d JerkAt(double t_s) const { return Evaluate(t_s, 3).head<3>(); }

 private:
  struct Piece {
    double start_s = 0;
    double duration_s = 0;
    /// Row a holds c_{a,0} … c_{a,5}.
    Eigen::Matrix<double, Eigen::Dynamic, kCoefficientsPerAxis, Eigen::RowMajor> coefficients;
  };

  PolynomialTrajectory() = default;
  /// Index of the piece holding global time t_s ∈ [0, duration_s()].
  std::size_t PieceAt(double t_s) const;

  int dimension_ = 3;
  double duration_s_ = 0;
  std::vector<Piece> pieces_;
};

}  // namespace strata::client
