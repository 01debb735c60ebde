#pragma once
/// Trajectories with known extremes for tests of the verifier and the benchmark's checks.
/// Header-only, test code only.
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "strata/robot_profile.hpp"
#include "strata/trajectory.hpp"

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

/// The built-in profile `name` with speed and acceleration bounds of 10 m/s and 10 m/s², far
/// above any test trajectory's, so that only the quantity a test is about can fail.
inline RobotProfile LooseProfile(const std::string& name) {
  RobotProfile profile = BuiltinProfile(name).value();
  profile.max_speed_horizontal_mps = profile.max_speed_vertical_mps = 10;
  profile.max_accel_horizontal_mps2 = profile.max_accel_vertical_mps2 = 10;
  return profile;
}

}  // namespace strata::test_util
