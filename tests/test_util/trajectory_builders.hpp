#pragma once
/// Trajectories with known extremes for tests of the verifier and the benchmark's checks.
/// Header-only, test code only.
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata::test_util {

/// Peak of σ'(s) = 30 s²(1 − s)² (at s = 1/2) for the minimum-jerk blend σ below.
inline constexpr double kMinimumJerkPeakSpeed = 1.875;
/// Peak of |σ''(s)| = |60 (s − 3s² + 2s³)| (at s = 1/2 ∓ √3/6): 10/√3.
inline const double kMinimumJerkPeakAcceleration = 10.0 / std::sqrt(3.0);

/// The rest-to-rest minimum-jerk motion from `from` to `to` (same dimension, 3 or 4) over
/// duration_s: p(t) = from + (to − from)·σ(t/T), σ(s) = 10s³ − 15s⁴ + 6s⁵. Along any axis the
/// speed peaks at kMinimumJerkPeakSpeed·|Δ|/T and the acceleration at
/// kMinimumJerkPeakAcceleration·|Δ|/T². Split into `pieces` pieces of equal duration, each
/// re-expanded about its own start.
inline Trajectory MinimumJerk(const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                              double duration_s, int pieces = 1) {
  Trajectory trajectory;
  trajectory.dimension = static_cast<int>(from.size());
  // Global polynomial per axis, lowest order first, in global time t.
  const double T = duration_s;
  Eigen::Matrix<double, 6, Eigen::Dynamic> global =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, from.size());
  for (Eigen::Index a = 0; a < from.size(); ++a) {
    const double delta = to(a) - from(a);
    global(0, a) = from(a);
    global(3, a) = 10 * delta / std::pow(T, 3);
    global(4, a) = -15 * delta / std::pow(T, 4);
    global(5, a) = 6 * delta / std::pow(T, 5);
  }
  const double piece_s = T / pieces;
  for (int i = 0; i < pieces; ++i) {
    // Taylor coefficients about the piece's start S: c'_k = Σ_j C(j, k) c_j S^(j−k).
    const double start = i * piece_s;
    TrajectoryPiece piece;
    piece.duration_s = piece_s;
    piece.coefficients = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, from.size());
    for (int k = 0; k < 6; ++k) {
      for (int j = k; j < 6; ++j) {
        double binomial = 1;
        for (int m = 0; m < k; ++m) binomial = binomial * (j - m) / (m + 1);
        piece.coefficients.row(k) += binomial * std::pow(start, j - k) * global.row(j);
      }
    }
    trajectory.pieces.push_back(piece);
  }
  return trajectory;
}

/// How a robot moves over a flat floor at z = 0 (FloorMotion below).
struct FloorMotionSpec {
  double rise_m = 0;     ///< z goes from −rise/2 to +rise/2 around the reference height [m].
  double offset_m = 0;   ///< ... shifted by this [m].
  double body_m = 0.65;  ///< Active-height profiles: the body height held throughout [m].
  int pieces = 1;        ///< Pieces of equal duration.
};

/// Rest to rest (MinimumJerk) from (x, y) `from` to `to` over a flat floor at z = 0, the
/// reference point at the profile's reference height (see FloorMotionSpec), in duration_s;
/// dimension 4 for active-height profiles.
inline Trajectory FloorMotion(const RobotProfile& profile, const Eigen::Vector2d& from,
                              const Eigen::Vector2d& to, double duration_s,
                              const FloorMotionSpec& spec = {}) {
  const double z = profile.reference_height_m + spec.offset_m;
  Eigen::VectorXd a(profile.active_height ? 4 : 3), b(a.size());
  a.head<3>() << from.x(), from.y(), z - spec.rise_m / 2;
  b.head<3>() << to.x(), to.y(), z + spec.rise_m / 2;
  if (profile.active_height) a(3) = b(3) = spec.body_m;
  return MinimumJerk(a, b, duration_s, spec.pieces);
}

/// The built-in profile `name` with speed and acceleration bounds of 10 m/s and 10 m/s², far
/// above any test trajectory's, so that only the quantity a test is about can fail.
inline RobotProfile LooseProfile(const std::string& name) {
  RobotProfile profile = BuiltinProfile(name).value();
  profile.max_speed_horizontal_mps = profile.max_speed_vertical_mps = 10;
  profile.max_accel_horizontal_mps2 = profile.max_accel_vertical_mps2 = 10;
  return profile;
}

/// A piece moving from `from` at constant `velocity` for `duration_s` (x, y, z).
inline TrajectoryPiece LinePiece(const Eigen::Vector3d& from, const Eigen::Vector3d& velocity,
                                 double duration_s) {
  TrajectoryPiece piece;
  piece.duration_s = duration_s;
  piece.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  piece.coefficients.row(0) = from.transpose();
  piece.coefficients.row(1) = velocity.transpose();
  return piece;
}

}  // namespace strata::test_util
