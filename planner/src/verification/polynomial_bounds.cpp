#include "strata/verification/polynomial_bounds.hpp"

#include <algorithm>
#include <vector>

namespace strata {
namespace {

// Intervals MaximumOn may split before it settles for the bounds it has: a quintic's speed or
// acceleration needs a few dozen to reach 1e-9 of its scale.
constexpr int kMaxSplits = 4096;

// C(i, j) / C(n, j), the weight of power coefficient j in Bernstein coefficient i of a
// polynomial of degree n, for every n <= kMaxPolynomialDegree: one table, built once.
struct BernsteinWeights {
  double weight[kMaxPolynomialDegree + 1][kMaxPolynomialDegree + 1][kMaxPolynomialDegree + 1];
  BernsteinWeights() {
    double binomial[kMaxPolynomialDegree + 1][kMaxPolynomialDegree + 1] = {};
    for (int n = 0; n <= kMaxPolynomialDegree; ++n) {
      binomial[n][0] = 1;
      for (int k = 1; k <= n; ++k)
        binomial[n][k] = binomial[n - 1][k - 1] + (k < n ? binomial[n - 1][k] : 0);
    }
    for (int n = 0; n <= kMaxPolynomialDegree; ++n) {
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= i; ++j) weight[n][i][j] = binomial[i][j] / binomial[n][j];
      }
    }
  }
};
const BernsteinWeights kBernsteinWeights;

}  // namespace

double Evaluate(const Polynomial& p, double t) {
  double value = 0;
  for (Eigen::Index k = p.size() - 1; k >= 0; --k) value = value * t + p(k);
  return value;
}

Polynomial Derivative(const Polynomial& p) {
  if (p.size() <= 1) return Polynomial::Zero(1);
  Polynomial d(p.size() - 1);
  for (Eigen::Index k = 1; k < p.size(); ++k) d(k - 1) = static_cast<double>(k) * p(k);
  return d;
}

Polynomial Product(const Polynomial& a, const Polynomial& b) {
  Polynomial product = Polynomial::Zero(a.size() + b.size() - 1);
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    for (Eigen::Index j = 0; j < b.size(); ++j) product(i + j) += a(i) * b(j);
  }
  return product;
}

Polynomial BernsteinCoefficients(const Polynomial& p, double a, double b) {
  const int n = static_cast<int>(p.size()) - 1;
  // q(u) = p(a + u) by repeated synthetic division (Taylor shift), then q(w s), w = b − a.
  Polynomial q = p;
  for (int i = 0; i < n; ++i) {
    for (int j = n - 1; j >= i; --j) q(j) += a * q(j + 1);
  }
  const double width = b - a;
  double scale = 1;
  for (int k = 0; k <= n; ++k, scale *= width) q(k) *= scale;
  // β_i = Σ_{j<=i} C(i, j) / C(n, j) · q_j.
  Polynomial beta = Polynomial::Zero(n + 1);
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= i; ++j) beta(i) += kBernsteinWeights.weight[n][i][j] * q(j);
  }
  return beta;
}

PolynomialRange RangeOn(const Polynomial& p, double a, double b) {
  if (!(b > a)) {
    const double value = Evaluate(p, a);
    return {value, value};
  }
  const Polynomial beta = BernsteinCoefficients(p, a, b);
  return {beta.minCoeff(), beta.maxCoeff()};
}

PolynomialMaximum MaximumOn(const Polynomial& p, double a, double b, double tolerance) {
  PolynomialMaximum best;
  best.at = a;
  best.value = Evaluate(p, a);
  if (const double end = Evaluate(p, b); end > best.value) {
    best.value = end;
    best.at = b;
  }
  best.upper = best.value;
  if (!(b > a)) return best;
  // Open intervals, the one with the highest bound on top.
  struct Open {
    double low, high, upper;
    bool operator<(const Open& other) const { return upper < other.upper; }
  };
  std::vector<Open> open{{a, b, BernsteinCoefficients(p, a, b).maxCoeff()}};
  double settled = best.value;  // The highest bound of the intervals let go.
  for (int splits = 0; !open.empty(); ++splits) {
    const Open top = open.front();
    if (top.upper <= best.value + tolerance || splits == kMaxSplits) {
      best.upper = std::max({best.value, top.upper, settled});
      return best;
    }
    std::pop_heap(open.begin(), open.end());
    open.pop_back();
    const double mid = 0.5 * (top.low + top.high);
    if (const double value = Evaluate(p, mid); value > best.value) {
      best.value = value;
      best.at = mid;
    }
    for (const auto& [low, high] : {std::pair{top.low, mid}, std::pair{mid, top.high}}) {
      const double upper = BernsteinCoefficients(p, low, high).maxCoeff();
      if (upper > best.value + tolerance) {
        open.push_back({low, high, upper});
        std::push_heap(open.begin(), open.end());
      } else {
        settled = std::max(settled, upper);
      }
    }
  }
  best.upper = std::max(settled, best.value);
  return best;
}

}  // namespace strata
