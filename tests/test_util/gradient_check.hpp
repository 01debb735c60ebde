#pragma once
/// Central finite differences for gradient tests, and their per-block comparison (header-only,
/// test code only).
///
/// Central differences have truncation error O(h²·|f'''|) and rounding error O(ε·|f|/h); for
/// a function that is polynomial of degree <= 2 along each axis (e.g. a trilinear interpolant
/// inside one cell) only the rounding error remains, so a small h is exact to ~1e-10.

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
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

/// A named part of a gradient vector: entries [offset, offset + size).
struct GradientBlock {
  std::string name;
  Eigen::Index offset = 0;
  Eigen::Index size = 0;
};

/// Compares two gradients block by block: in every block, ‖analytic − numeric‖ must stay
/// within `relative` × the larger of their norms plus `noise`, so an error in a block of
/// small entries cannot hide under a block of large ones. `noise` is the absolute error of
/// the finite differences themselves (FiniteDifferenceNoise). Fails naming every block out
/// of tolerance, with both vectors.
inline ::testing::AssertionResult GradientsMatchPerBlock(const Eigen::VectorXd& analytic,
                                                         const Eigen::VectorXd& numeric,
                                                         const std::vector<GradientBlock>& blocks,
                                                         double relative, double noise) {
  std::ostringstream failures;
  for (const GradientBlock& b : blocks) {
    const Eigen::VectorXd a = analytic.segment(b.offset, b.size);
    const Eigen::VectorXd n = numeric.segment(b.offset, b.size);
    const double error = (a - n).norm();
    const double allowed = relative * std::max(a.norm(), n.norm()) + noise;
    if (!(error <= allowed)) {
      failures << "block " << b.name << ": error " << error << " > " << allowed << "\n  analytic "
               << a.transpose() << "\n  numeric  " << n.transpose() << "\n";
    }
  }
  if (failures.str().empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << failures.str();
}

/// A gradient over x = [waypoints (dim × count, stored waypoint by waypoint), rest] with the
/// waypoints reordered axis by axis, so that each axis is one block (WaypointAxisBlocks).
inline Eigen::VectorXd WaypointsByAxis(const Eigen::VectorXd& gradient, int dim, int count) {
  Eigen::VectorXd out = gradient;
  out.head(dim * count) =
      Eigen::Map<const Eigen::MatrixXd>(gradient.data(), dim, count).transpose().reshaped();
  return out;
}

/// The blocks of a WaypointsByAxis vector: "waypoint axis a" for each axis, then `rest` (its
/// last rest_size entries).
inline std::vector<GradientBlock> WaypointAxisBlocks(int dim, int count, const std::string& rest,
                                                     Eigen::Index rest_size) {
  std::vector<GradientBlock> blocks;
  for (int a = 0; a < dim; ++a)
    blocks.push_back({"waypoint axis " + std::to_string(a), a * count, count});
  blocks.push_back({rest, Eigen::Index{dim} * count, rest_size});
  return blocks;
}

/// The absolute error of central differences with step h of a function of magnitude |f|
/// evaluated to a relative precision of about 1e-14 (a hundred ulps, for a cost summed over
/// many terms): 1e-14·max(1, |f|)/h. Truncation error is not included: keep h small.
inline double FiniteDifferenceNoise(double f, double h) {
  return 1e-14 * std::max(1.0, std::abs(f)) / h;
}

}  // namespace strata::test_util
