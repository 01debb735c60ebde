#pragma once
// Builds Trajectory protos for client tests: from explicit coefficients, by splitting one
// global polynomial into pieces (re-expanded about each piece's start), and as quintic
// Hermite interpolants of a known curve.
#include <array>
#include <vector>

#include <Eigen/Dense>

#include "strata/v1/trajectory.pb.h"

namespace strata::client::testing {

using Coefficients = std::array<double, 6>;  // c_0 … c_5, lowest order first.

struct PieceSpec {
  double duration_s;
  std::vector<Coefficients> axes;  // One per axis.
};

inline v1::Trajectory MakeTrajectory(int dimension, const std::vector<PieceSpec>& pieces) {
  v1::Trajectory trajectory;
  trajectory.set_frame("map");
  trajectory.set_dimension(dimension);
  double total = 0;
  for (const PieceSpec& spec : pieces) {
    v1::TrajectoryPiece* piece = trajectory.add_pieces();
    piece->set_duration_s(spec.duration_s);
    for (const Coefficients& c : spec.axes) {
      v1::Polynomial* axis = piece->add_axes();
      for (double value : c) axis->add_coefficients(value);
    }
    total += spec.duration_s;
  }
  trajectory.set_duration_s(total);
  return trajectory;
}

// k-th derivative of Σ c_j t^j at t, by direct summation of the power series (no Horner).
inline double PowerSeriesDerivative(const Coefficients& c, double t, int k) {
  double sum = 0;
  for (int j = k; j < 6; ++j) {
    double factor = 1;
    for (int m = 0; m < k; ++m) factor *= j - m;
    double power = 1;
    for (int m = 0; m < j - k; ++m) power *= t;
    sum += factor * c[j] * power;
  }
  return sum;
}

// The coefficients of c(S + t) in t: c'_k = c^(k)(S) / k!.
inline Coefficients ShiftPolynomial(const Coefficients& c, double start_s) {
  Coefficients shifted{};
  double factorial = 1;
  for (int k = 0; k < 6; ++k) {
    if (k > 0) factorial *= k;
    shifted[k] = PowerSeriesDerivative(c, start_s, k) / factorial;
  }
  return shifted;
}

// The quintic on [0, T] with the given position, velocity and acceleration at both ends.
inline Coefficients QuinticHermite(double p0, double v0, double a0, double p1, double v1, double a1,
                                   double T) {
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b;
  b << p0, v0, a0, p1, v1, a1;
  m(0, 0) = 1;
  m(1, 1) = 1;
  m(2, 2) = 2;
  for (int j = 0; j < 6; ++j) {
    m(3, j) = std::pow(T, j);
    if (j >= 1) m(4, j) = j * std::pow(T, j - 1);
    if (j >= 2) m(5, j) = j * (j - 1) * std::pow(T, j - 2);
  }
  const Eigen::Matrix<double, 6, 1> c = m.fullPivLu().solve(b);
  return {c[0], c[1], c[2], c[3], c[4], c[5]};
}

}  // namespace strata::client::testing
