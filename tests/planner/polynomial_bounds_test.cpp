// The Bernstein enclosures the verifier proves its kinematic rules with: they must contain
// every value of the polynomial on the interval, and the branch and bound must find the
// maximum where sampling would miss it.
#include "strata/verification/polynomial_bounds.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace strata {
namespace {

Polynomial Of(std::initializer_list<double> coefficients) {
  Polynomial p(static_cast<Eigen::Index>(coefficients.size()));
  Eigen::Index k = 0;
  for (const double c : coefficients) p(k++) = c;
  return p;
}

Polynomial Random(std::mt19937& rng, int degree) {
  std::uniform_real_distribution<double> coefficient(-3, 3);
  Polynomial p(degree + 1);
  for (int k = 0; k <= degree; ++k) p(k) = coefficient(rng);
  return p;
}

TEST(Polynomial, ProductAndDerivativeMatchTheirDefinitions) {
  const Polynomial a = Of({1, -2, 0.5}), b = Of({3, 0, 0, 2});
  const Polynomial product = Product(a, b);
  ASSERT_EQ(product.size(), 6);
  const Polynomial derivative = Derivative(product);
  for (const double t : {-1.3, 0.0, 0.4, 2.5}) {
    EXPECT_NEAR(Evaluate(product, t), Evaluate(a, t) * Evaluate(b, t), 1e-12);
    const double h = 1e-6;
    EXPECT_NEAR(Evaluate(derivative, t),
                (Evaluate(product, t + h) - Evaluate(product, t - h)) / (2 * h), 1e-5);
  }
}

TEST(Polynomial, BernsteinCoefficientsEnclose) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const int degree = 1 + trial % 8;
    const Polynomial p = Random(rng, degree);
    const double a = std::uniform_real_distribution<double>(-2, 1)(rng);
    const double b = a + std::uniform_real_distribution<double>(1e-3, 3)(rng);
    const Polynomial beta = BernsteinCoefficients(p, a, b);
    ASSERT_EQ(beta.size(), degree + 1);
    // The ends are interpolated...
    EXPECT_NEAR(beta(0), Evaluate(p, a), 1e-9 * (1 + std::abs(beta(0))));
    EXPECT_NEAR(beta(degree), Evaluate(p, b), 1e-9 * (1 + std::abs(beta(degree))));
    // ...and every value lies in the coefficients' range.
    const PolynomialRange range = RangeOn(p, a, b);
    for (int k = 0; k <= 1000; ++k) {
      const double value = Evaluate(p, a + (b - a) * k / 1000);
      ASSERT_GE(value, range.low - 1e-9 * (1 + std::abs(value))) << "trial " << trial;
      ASSERT_LE(value, range.high + 1e-9 * (1 + std::abs(value))) << "trial " << trial;
    }
  }
}

TEST(Polynomial, MaximumIsBracketedWithinTheTolerance) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const Polynomial p = Random(rng, 1 + trial % 8);
    const double tolerance = 1e-9;
    const PolynomialMaximum m = MaximumOn(p, -1, 2, tolerance);
    double sampled = -INFINITY;
    for (int k = 0; k <= 30000; ++k) sampled = std::max(sampled, Evaluate(p, -1 + 3.0 * k / 30000));
    EXPECT_GE(m.upper, sampled - 1e-12) << "trial " << trial;
    EXPECT_LE(m.upper - m.value, tolerance + 1e-12) << "trial " << trial;
    EXPECT_NEAR(Evaluate(p, m.at), m.value, 1e-12);
    EXPECT_GE(m.at, -1);
    EXPECT_LE(m.at, 2);
  }
}

// A peak narrower than samples 2 ms apart (a quartic 1 − 1e13 (t − 0.011)⁴, above 0 only
// within ±0.56 ms of its top) is found: sampled at 0, 2, ..., 20 ms it never rises above 0.
TEST(Polynomial, MaximumFindsAPeakBetweenSamples) {
  const double c = 0.011, k = 1e13;
  // 1 − k (t − c)⁴ expanded.
  const Polynomial p =
      Of({1 - k * std::pow(c, 4), 4 * k * std::pow(c, 3), -6 * k * c * c, 4 * k * c, -k});
  for (int sample = 0; sample <= 10; ++sample) ASSERT_LE(Evaluate(p, 0.002 * sample), 0);
  const PolynomialMaximum m = MaximumOn(p, 0, 0.02, 1e-9);
  EXPECT_NEAR(m.value, 1, 1e-6);
  EXPECT_NEAR(m.at, c, 1e-4);
  EXPECT_GE(m.upper, 1 - 1e-6);
}

TEST(Polynomial, AConstantAndAPointIntervalAreTheirValue) {
  const PolynomialMaximum constant = MaximumOn(Of({2.5}), 0, 1, 1e-9);
  EXPECT_EQ(constant.upper, 2.5);
  EXPECT_EQ(constant.value, 2.5);
  const PolynomialMaximum point = MaximumOn(Of({0, 1, 1}), 3, 3, 1e-9);
  EXPECT_EQ(point.upper, 12);
  const PolynomialRange range = RangeOn(Of({0, 1, 1}), 3, 3);
  EXPECT_EQ(range.low, 12);
  EXPECT_EQ(range.high, 12);
}

}  // namespace
}  // namespace strata
