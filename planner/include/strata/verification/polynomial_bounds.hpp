#pragma once
/// Bounds of a polynomial that hold everywhere on an interval, not only where it was sampled:
/// what lets the verifier prove speed, acceleration and body height between its samples.
///
/// On an interval [a, b] a polynomial of degree n is written in the Bernstein basis of that
/// interval, Σ_i β_i · C(n, i) s^i (1 − s)^(n − i) with s = (t − a) / (b − a). Its graph lies in
/// the convex hull of the control points (i / n, β_i), so min β ≤ p ≤ max β on [a, b], with
/// equality at the ends (β_0 = p(a), β_n = p(b)); splitting the interval shrinks the gap
/// between max β and the polynomial's maximum quadratically in the interval's width. This is
/// the enclosure the verifier relies on, exact up to rounding (docs/design.md §13).
#include <Eigen/Core>

namespace strata {

/// Highest degree these functions take: the squared norm of a quartic (a quintic's velocity).
inline constexpr int kMaxPolynomialDegree = 8;

/// Coefficients lowest order first: p(t) = Σ_k c_k t^k; at most kMaxPolynomialDegree + 1.
using Polynomial = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxPolynomialDegree + 1, 1>;

double Evaluate(const Polynomial& p, double t);
/// The derivative (degree one less; the zero polynomial for a constant).
Polynomial Derivative(const Polynomial& p);
/// a · b; their degrees must add up to at most kMaxPolynomialDegree.
Polynomial Product(const Polynomial& a, const Polynomial& b);

/// The Bernstein coefficients β_0..β_n of p on [a, b] (a < b), as above.
Polynomial BernsteinCoefficients(const Polynomial& p, double a, double b);

/// An enclosure of p's values on [a, b]: low <= p(t) <= high for every t there (the
/// Bernstein coefficients' extremes, without splitting: quick, and loose on a long interval).
struct PolynomialRange {
  double low = 0;
  double high = 0;
};
PolynomialRange RangeOn(const Polynomial& p, double a, double b);

/// The maximum of p on [a, b] (a <= b) by branch and bound over Bernstein coefficients:
/// value = p(at) for an `at` in [a, b], and value <= max p <= upper <= value + tolerance
/// (tolerance > 0). The largest of the upper bounds still open, so `upper` is a bound even
/// when the split budget (a few thousand intervals, far beyond what a quintic's derivatives
/// need) runs out first.
struct PolynomialMaximum {
  double upper = 0;
  double value = 0;
  double at = 0;
};
PolynomialMaximum MaximumOn(const Polynomial& p, double a, double b, double tolerance);

}  // namespace strata
