#pragma once
/// Central finite differences for gradient tests (header-only, test code only).
///
/// Central differences have truncation error O(h²·|f'''|) and rounding error O(ε·|f|/h); for
/// a function that is polynomial of degree <= 2 along each axis (e.g. a trilinear interpolant
/// inside one cell) only the rounding error remains, so a small h is exact to ~1e-10.

#include <algorithm>
#include <functional>

#include <Eigen/Core>

namespace strata::test_util {

/// ∇f(x) by central differences: g_i = (f(x + h·e_i) − f(x − h·e_i)) / (2h). h > 0.
inline Eigen::VectorXd NumericalGradient(const std::function<double(const Eigen::VectorXd&)>& f,
                                         const Eigen::VectorXd& x, double h) {
  Eigen::VectorXd gradient(x.size());
  Eigen::VectorXd probe = x;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    probe[i] = x[i] + h;
    const double plus = f(probe);
    probe[i] = x[i] - h;
    const double minus = f(probe);
    probe[i] = x[i];
    gradient[i] = (plus - minus) / (2.0 * h);
  }
  return gradient;
}

/// ∇f(p) of a 3D field (a distance field, a cost over positions) by central differences.
inline Eigen::Vector3d NumericalFieldGradient(
    const std::function<double(const Eigen::Vector3d&)>& f, const Eigen::Vector3d& p, double h) {
  Eigen::Vector3d gradient;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d plus = p;
    Eigen::Vector3d minus = p;
    plus[i] += h;
    minus[i] -= h;
    gradient[i] = (f(plus) - f(minus)) / (2.0 * h);
  }
  return gradient;
}

/// ‖a − b‖ / max(‖a‖, ‖b‖, floor): a relative error that stays meaningful near zero.
inline double RelativeError(const Eigen::VectorXd& a, const Eigen::VectorXd& b,
                            double floor = 1.0) {
  return (a - b).norm() / std::max({a.norm(), b.norm(), floor});
}

}  // namespace strata::test_util
