#include "strata/planning/minco.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <tuple>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "test_util/gradient_check.hpp"

namespace strata {
namespace {

using test_util::NumericalGradient;
using test_util::RelativeError;

// One random MINCO problem: boundary states, waypoints, durations.
struct Problem {
  Eigen::MatrixXd head;       // dim×3
  Eigen::MatrixXd tail;       // dim×3
  Eigen::MatrixXd waypoints;  // dim×(M−1)
  Eigen::VectorXd durations;  // M
};

Eigen::MatrixXd RandomMatrix(std::mt19937* rng, int rows, int cols, double lo, double hi) {
  std::uniform_real_distribution<double> dist(lo, hi);
  Eigen::MatrixXd m(rows, cols);
  for (int j = 0; j < cols; ++j) {
    for (int i = 0; i < rows; ++i) m(i, j) = dist(*rng);
  }
  return m;
}

Problem RandomProblem(std::mt19937* rng, int dim, int pieces) {
  Problem p;
  p.head = RandomMatrix(rng, dim, 3, -2.0, 2.0);
  p.tail = RandomMatrix(rng, dim, 3, -2.0, 2.0);
  p.waypoints = RandomMatrix(rng, dim, pieces - 1, -5.0, 5.0);
  p.durations = RandomMatrix(rng, pieces, 1, 0.5, 2.0);
  return p;
}

Minco3 Solve(const Problem& p) {
  Minco3 minco;
  minco.SetConditions(p.head, p.tail, static_cast<int>(p.durations.size()));
  minco.SetParameters(p.waypoints, p.durations);
  return minco;
}

// k!/(k−j)! t^(k−j): the j-th derivative of t^k, written out independently of the library.
double MonomialDerivative(int k, int j, double t) {
  if (k < j) return 0.0;
  double f = 1.0;
  for (int m = 0; m < j; ++m) f *= (k - m);
  return f * std::pow(t, k - j);
}

// The MINCO system assembled densely in the natural order (head; per joint: waypoint, then
// continuity of derivatives 0..4; tail), solved by full-pivoting LU.
Eigen::MatrixXd DenseReference(const Problem& p) {
  const int m = static_cast<int>(p.durations.size());
  const int dim = static_cast<int>(p.head.rows());
  const int n = 6 * m;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, dim);
  int row = 0;
  for (int j = 0; j < 3; ++j, ++row) {
    for (int k = 0; k < 6; ++k) a(row, k) = MonomialDerivative(k, j, 0.0);
    b.row(row) = p.head.col(j).transpose();
  }
  for (int i = 0; i + 1 < m; ++i) {
    const double t = p.durations[i];
    for (int k = 0; k < 6; ++k) a(row, 6 * i + k) = MonomialDerivative(k, 0, t);
    b.row(row++) = p.waypoints.col(i).transpose();
    for (int j = 0; j <= 4; ++j, ++row) {
      for (int k = 0; k < 6; ++k) {
        a(row, 6 * i + k) = MonomialDerivative(k, j, t);
        a(row, 6 * (i + 1) + k) = -MonomialDerivative(k, j, 0.0);
      }
    }
  }
  for (int j = 0; j < 3; ++j, ++row) {
    for (int k = 0; k < 6; ++k)
      a(row, 6 * (m - 1) + k) = MonomialDerivative(k, j, p.durations[m - 1]);
    b.row(row) = p.tail.col(j).transpose();
  }
  return a.fullPivLu().solve(b);
}

double RelErr(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return RelativeError(a, b, 1.0);
}

Eigen::VectorXd Flatten(const Eigen::MatrixXd& m) {
  return Eigen::Map<const Eigen::VectorXd>(m.data(), m.size());
}

class MincoSizes : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(MincoSizes, MeetsBoundaryStatesAndWaypoints) {
  const auto [dim, pieces] = GetParam();
  std::mt19937 rng(11 + 100 * dim + pieces);
  const Problem p = RandomProblem(&rng, dim, pieces);
  const Minco3 minco = Solve(p);
  const double total = p.durations.sum();
  EXPECT_NEAR(minco.TotalDuration(), total, 1e-12);
  EXPECT_LT(RelErr(minco.Position(0.0), p.head.col(0)), 1e-9);
  EXPECT_LT(RelErr(minco.Velocity(0.0), p.head.col(1)), 1e-9);
  EXPECT_LT(RelErr(minco.Acceleration(0.0), p.head.col(2)), 1e-9);
  EXPECT_LT(RelErr(minco.Position(total), p.tail.col(0)), 1e-9);
  EXPECT_LT(RelErr(minco.Velocity(total), p.tail.col(1)), 1e-9);
  EXPECT_LT(RelErr(minco.Acceleration(total), p.tail.col(2)), 1e-9);
  // Clamped outside [0, total].
  EXPECT_LT(RelErr(minco.Position(-1.0), p.head.col(0)), 1e-9);
  EXPECT_LT(RelErr(minco.Position(total + 1.0), p.tail.col(0)), 1e-9);

  const Eigen::MatrixXd& c = minco.coefficients();
  for (int i = 0; i + 1 < pieces; ++i) {
    const double t = p.durations[i];
    for (int j = 0; j <= 4; ++j) {
      Eigen::VectorXd end = Eigen::VectorXd::Zero(dim);
      Eigen::VectorXd start = Eigen::VectorXd::Zero(dim);
      for (int k = 0; k < 6; ++k) {
        end += MonomialDerivative(k, j, t) * c.row(6 * i + k).transpose();
        start += MonomialDerivative(k, j, 0.0) * c.row(6 * (i + 1) + k).transpose();
      }
      EXPECT_LT(RelErr(end, start), 1e-8) << "joint " << i << " derivative " << j;
      if (j == 0) {
        EXPECT_LT(RelErr(end, p.waypoints.col(i)), 1e-9) << "joint " << i;
      }
    }
  }
}

TEST_P(MincoSizes, CoefficientsMatchDenseSolve) {
  const auto [dim, pieces] = GetParam();
  std::mt19937 rng(23 + 100 * dim + pieces);
  const Problem p = RandomProblem(&rng, dim, pieces);
  const Minco3 minco = Solve(p);
  const Eigen::MatrixXd reference = DenseReference(p);
  ASSERT_EQ(minco.coefficients().rows(), 6 * pieces);
  ASSERT_EQ(minco.coefficients().cols(), dim);
  EXPECT_LT(RelErr(Flatten(minco.coefficients()), Flatten(reference)), 1e-9);
}

TEST_P(MincoSizes, JerkEnergyMatchesQuadrature) {
  const auto [dim, pieces] = GetParam();
  std::mt19937 rng(37 + 100 * dim + pieces);
  const Problem p = RandomProblem(&rng, dim, pieces);
  const Minco3 minco = Solve(p);
  // Composite Simpson per piece; ‖jerk‖² is a quartic, so the error is O(h⁴) and tiny.
  double quadrature = 0.0;
  const int intervals = 400;
  double start = 0.0;
  for (int i = 0; i < pieces; ++i) {
    const double h = p.durations[i] / intervals;
    for (int s = 0; s <= intervals; ++s) {
      const double weight = (s == 0 || s == intervals) ? 1.0 : (s % 2 == 1 ? 4.0 : 2.0);
      // Sample strictly inside the piece so that LocatePiece picks piece i at its ends.
      const double t = start + std::clamp(s * h, 1e-12, p.durations[i] - 1e-12);
      quadrature += weight * h / 3.0 * minco.Jerk(t).squaredNorm();
    }
    start += p.durations[i];
  }
  const double energy = minco.JerkEnergy(nullptr, nullptr);
  EXPECT_NEAR(energy, quadrature, 1e-7 * std::max(1.0, quadrature));
}

TEST_P(MincoSizes, JerkEnergyGradientMatchesFiniteDifferences) {
  const auto [dim, pieces] = GetParam();
  std::mt19937 rng(41 + 100 * dim + pieces);
  const Problem p = RandomProblem(&rng, dim, pieces);
  const Minco3 minco = Solve(p);
  Eigen::MatrixXd grad_c;
  Eigen::VectorXd grad_T;
  const double energy = minco.JerkEnergy(&grad_c, &grad_T);
  // The accumulators add: a second call doubles them and returns the same value.
  Eigen::MatrixXd grad_c2 = grad_c;
  Eigen::VectorXd grad_T2 = grad_T;
  EXPECT_EQ(minco.JerkEnergy(&grad_c2, &grad_T2), energy);
  EXPECT_LT(RelErr(Flatten(grad_c2), 2.0 * Flatten(grad_c)), 1e-14);
  EXPECT_LT(RelErr(grad_T2, 2.0 * grad_T), 1e-14);

  // The closed form as a function of (c, T) alone: the energy of a Minco3 is read from its
  // coefficients and durations, so re-derive it here from the formula in docs/design.md §11.
  const auto energy_of = [pieces = pieces](const Eigen::MatrixXd& c, const Eigen::VectorXd& t) {
    double e = 0.0;
    for (int i = 0; i < pieces; ++i) {
      const double step = t[i];
      // Gauss–Legendre with 3 nodes integrates a quartic exactly.
      const double nodes[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
      const double weights[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
      for (int q = 0; q < 3; ++q) {
        const double s = 0.5 * step * (nodes[q] + 1.0);
        const Eigen::VectorXd jerk =
            (6.0 * c.row(6 * i + 3) + 24.0 * s * c.row(6 * i + 4) + 60.0 * s * s * c.row(6 * i + 5))
                .transpose();
        e += 0.5 * step * weights[q] * jerk.squaredNorm();
      }
    }
    return e;
  };
  const Eigen::MatrixXd& c0 = minco.coefficients();
  EXPECT_NEAR(energy_of(c0, p.durations), energy, 1e-9 * energy);
  const Eigen::VectorXd fd_c = NumericalGradient(
      [&](const Eigen::VectorXd& x) {
        return energy_of(Eigen::Map<const Eigen::MatrixXd>(x.data(), c0.rows(), c0.cols()),
                         p.durations);
      },
      Flatten(c0), 1e-5);
  EXPECT_LT(RelErr(Flatten(grad_c), fd_c), 1e-5);
  const Eigen::VectorXd fd_T = NumericalGradient(
      [&](const Eigen::VectorXd& t) { return energy_of(c0, t); }, p.durations, 1e-6);
  EXPECT_LT(RelErr(grad_T, fd_T), 1e-5);
}

// A test cost K(c, T) = Σ w∘c + ½ Σ (d∘c)² + Σ (a_i T_i² + sin T_i), with its explicit partials.
struct TestCost {
  Eigen::MatrixXd w, d;
  Eigen::VectorXd a;
  double Evaluate(const Eigen::MatrixXd& c, const Eigen::VectorXd& t, Eigen::MatrixXd* grad_c,
                  Eigen::VectorXd* grad_T) const {
    const Eigen::ArrayXXd dc = d.array() * c.array();
    if (grad_c != nullptr) *grad_c += (w.array() + d.array() * dc).matrix();
    if (grad_T != nullptr) {
      *grad_T += (2.0 * a.array() * t.array() + t.array().cos()).matrix();
    }
    return (w.array() * c.array()).sum() + 0.5 * dc.square().sum() +
           (a.array() * t.array().square() + t.array().sin()).sum();
  }
};

TEST_P(MincoSizes, PropagateGradientMatchesFiniteDifferences) {
  // Plain variables, not a structured binding: the lambdas below capture them (clang 14, the
  // sanitised build's compiler, cannot capture bindings).
  const int dim = std::get<0>(GetParam());
  const int pieces = std::get<1>(GetParam());
  std::mt19937 rng(53 + 100 * dim + pieces);
  const Problem p = RandomProblem(&rng, dim, pieces);
  TestCost cost;
  cost.w = RandomMatrix(&rng, 6 * pieces, dim, -1.0, 1.0);
  cost.d = RandomMatrix(&rng, 6 * pieces, dim, -0.3, 0.3);
  cost.a = RandomMatrix(&rng, pieces, 1, 0.0, 2.0);

  for (const bool with_jerk : {false, true}) {
    SCOPED_TRACE(with_jerk ? "test cost + jerk energy" : "test cost");
    // K(q, T) = cost(M(q, T), T) [+ JerkEnergy].
    const auto objective = [&](const Eigen::MatrixXd& q, const Eigen::VectorXd& t) {
      Minco3 minco;
      minco.SetConditions(p.head, p.tail, pieces);
      minco.SetParameters(q, t);
      double k = cost.Evaluate(minco.coefficients(), t, nullptr, nullptr);
      if (with_jerk) k += minco.JerkEnergy(nullptr, nullptr);
      return k;
    };

    const Minco3 minco = Solve(p);
    Eigen::MatrixXd grad_c = Eigen::MatrixXd::Zero(6 * pieces, dim);
    Eigen::VectorXd grad_T = Eigen::VectorXd::Zero(pieces);
    cost.Evaluate(minco.coefficients(), p.durations, &grad_c, &grad_T);
    if (with_jerk) minco.JerkEnergy(&grad_c, &grad_T);
    Eigen::MatrixXd grad_q;
    Eigen::VectorXd grad_durations;
    minco.PropagateGradient(grad_c, grad_T, &grad_q, &grad_durations);
    ASSERT_EQ(grad_q.rows(), dim);
    ASSERT_EQ(grad_q.cols(), pieces - 1);
    ASSERT_EQ(grad_durations.size(), pieces);

    if (pieces > 1) {
      const Eigen::VectorXd fd_q = NumericalGradient(
          [&](const Eigen::VectorXd& x) {
            return objective(Eigen::Map<const Eigen::MatrixXd>(x.data(), dim, pieces - 1),
                             p.durations);
          },
          Flatten(p.waypoints), 1e-5);
      EXPECT_LT(RelErr(Flatten(grad_q), fd_q), 1e-5);
    }
    const Eigen::VectorXd fd_T = NumericalGradient(
        [&](const Eigen::VectorXd& t) { return objective(p.waypoints, t); }, p.durations, 1e-6);
    EXPECT_LT(RelErr(grad_durations, fd_T), 1e-5)
        << "adjoint " << grad_durations.transpose() << "\nfd      " << fd_T.transpose();
  }
}

// Dimension 2 takes the solves' general path; 3 and 4 their unrolled ones (minco.cpp).
INSTANTIATE_TEST_SUITE_P(DimsAndPieces, MincoSizes,
                         ::testing::Combine(::testing::Values(2, 3, 4),
                                            ::testing::Values(1, 2, 5, 12)),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           return "dim" + std::to_string(std::get<0>(info.param)) + "_pieces" +
                                  std::to_string(std::get<1>(info.param));
                         });

TEST(Minco3, OnePieceIsTheQuinticThroughTheBoundaryStates) {
  std::mt19937 rng(7);
  const Eigen::MatrixXd head = RandomMatrix(&rng, 3, 3, -2.0, 2.0);
  const Eigen::MatrixXd tail = RandomMatrix(&rng, 3, 3, -2.0, 2.0);
  const double t = 1.7;
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 3> b;
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 6; ++k) {
      a(j, k) = MonomialDerivative(k, j, 0.0);
      a(3 + j, k) = MonomialDerivative(k, j, t);
    }
    b.row(j) = head.col(j).transpose();
    b.row(3 + j) = tail.col(j).transpose();
  }
  const Eigen::Matrix<double, 6, 3> reference = a.partialPivLu().solve(b);

  Minco3 minco;
  minco.SetConditions(head, tail, 1);
  minco.SetParameters(Eigen::MatrixXd(3, 0), Eigen::VectorXd::Constant(1, t));
  EXPECT_EQ(minco.piece_count(), 1);
  EXPECT_EQ(minco.dim(), 3);
  EXPECT_LT((minco.coefficients() - reference).norm(), 1e-10 * reference.norm());
}

TEST(Minco3, PivotFreeSolveStaysAccurateForWidelyVaryingDurations) {
  // LU without pivoting relies on the row order; check it against full pivoting when piece
  // durations span two orders of magnitude.
  std::mt19937 rng(19);
  for (int trial = 0; trial < 5; ++trial) {
    Problem p = RandomProblem(&rng, 3, 20);
    std::uniform_real_distribution<double> log_t(std::log(0.05), std::log(5.0));
    for (int i = 0; i < 20; ++i) p.durations[i] = std::exp(log_t(rng));
    const Minco3 minco = Solve(p);
    const Eigen::MatrixXd reference = DenseReference(p);
    EXPECT_LT(RelErr(Flatten(minco.coefficients()), Flatten(reference)), 1e-8) << "trial " << trial;
  }
}

TEST(Minco3, StraightLineAtConstantSpeedIsExactAndHasNoJerk) {
  // A constant-velocity line through evenly timed waypoints is the minimum-jerk solution.
  const int pieces = 6;
  const Eigen::Vector3d vel(0.5, -0.2, 0.1);
  Eigen::MatrixXd head = Eigen::MatrixXd::Zero(3, 3);
  Eigen::MatrixXd tail = Eigen::MatrixXd::Zero(3, 3);
  head.col(1) = vel;
  tail.col(0) = vel * 1.5 * pieces;
  tail.col(1) = vel;
  Eigen::MatrixXd waypoints(3, pieces - 1);
  for (int i = 0; i + 1 < pieces; ++i) waypoints.col(i) = vel * 1.5 * (i + 1);
  Minco3 minco;
  minco.SetConditions(head, tail, pieces);
  minco.SetParameters(waypoints, Eigen::VectorXd::Constant(pieces, 1.5));
  EXPECT_LT(minco.JerkEnergy(nullptr, nullptr), 1e-18);
  for (double t = 0.0; t <= 9.0; t += 0.37) {
    EXPECT_LT((minco.Position(t) - vel * t).norm(), 1e-12);
    EXPECT_LT((minco.Velocity(t) - vel).norm(), 1e-12);
  }
}

// Fills the entries (i, j) of *band's band for which in_pattern(i, j) holds with random values,
// diagonally dominant so that no pivoting is needed, and returns the same matrix dense.
template <typename Pattern>
Eigen::MatrixXd FillDiagonallyDominant(int lower, int upper, Pattern in_pattern, std::mt19937* rng,
                                       BandedSystem* band) {
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  const int n = band->size();
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = std::max(0, i - lower); j <= std::min(n - 1, i + upper); ++j) {
      if (!in_pattern(i, j)) continue;
      dense(i, j) = (i == j) ? 10.0 + dist(*rng) : dist(*rng);
      (*band)(i, j) = dense(i, j);
    }
  }
  return dense;
}

// Factorises *band and checks both solves against `dense` on a random right-hand side.
void ExpectSolvesLikeDense(const Eigen::MatrixXd& dense, int columns, std::mt19937* rng,
                           BandedSystem* band) {
  band->Factorize();
  const Eigen::MatrixXd rhs = RandomMatrix(rng, static_cast<int>(dense.rows()), columns, -1.0, 1.0);
  Eigen::MatrixXd x = rhs;
  band->Solve(&x);
  EXPECT_LT((dense * x - rhs).norm(), 1e-12);
  Eigen::MatrixXd y = rhs;
  band->SolveTransposed(&y);
  EXPECT_LT((dense.transpose() * y - rhs).norm(), 1e-12);
}

TEST(BandedSystem, SolvesAndSolvesTransposedLikeADenseMatrix) {
  std::mt19937 rng(5);
  const int lower = 2;
  const int upper = 3;
  BandedSystem band;
  band.Reset(20, lower, upper);
  const Eigen::MatrixXd dense = FillDiagonallyDominant(
      lower, upper, [](int, int) { return true; }, &rng, &band);
  ExpectSolvesLikeDense(dense, 2, &rng, &band);
}

// A band with holes, as MINCO's: the factors fill some of them in (Analyze must find those),
// and a second matrix of the same pattern, after Clear, reuses the first one's analysis.
TEST(BandedSystem, SolvesASparseBandLikeADenseMatrixAndReusesItsPattern) {
  std::mt19937 rng(9);
  const int lower = 3;
  const int upper = 2;
  // The first subdiagonal is empty, and elimination fills it in: (k + 2, k + 1) from L(k + 2, k)
  // and U(k, k + 1).
  const auto in_pattern = [](int i, int j) { return i - j != 1; };
  BandedSystem band;
  band.Reset(24, lower, upper);
  for (int round = 0; round < 2; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    if (round > 0) band.Clear();
    const Eigen::MatrixXd dense = FillDiagonallyDominant(lower, upper, in_pattern, &rng, &band);
    ExpectSolvesLikeDense(dense, 3, &rng, &band);
  }
}

TEST(DurationMap, IsPositiveIncreasingAndC2AtZero) {
  EXPECT_DOUBLE_EQ(DurationFromTau(0.0), 1.0);
  EXPECT_DOUBLE_EQ(DurationGradient(0.0), 1.0);
  const double h = 1e-4;
  // One-sided second differences on each side both approach T''(0) = 1.
  const double left =
      (DurationFromTau(0.0) - 2.0 * DurationFromTau(-h) + DurationFromTau(-2.0 * h)) / (h * h);
  const double right =
      (DurationFromTau(2.0 * h) - 2.0 * DurationFromTau(h) + DurationFromTau(0.0)) / (h * h);
  EXPECT_NEAR(left, 1.0, 1e-3);
  EXPECT_NEAR(right, 1.0, 1e-3);
  // Values and first derivatives meet at 0 from both sides.
  EXPECT_NEAR(DurationFromTau(-1e-9), DurationFromTau(1e-9), 1e-8);
  EXPECT_NEAR(DurationGradient(-1e-9), DurationGradient(1e-9), 1e-8);

  double previous = 0.0;
  for (double tau = -30.0; tau <= 30.0; tau += 0.25) {
    const double t = DurationFromTau(tau);
    EXPECT_GT(t, previous) << "tau " << tau;
    EXPECT_GT(DurationGradient(tau), 0.0) << "tau " << tau;
    previous = t;
  }
}

TEST(DurationMap, InverseRoundTrips) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> dist(-10.0, 10.0);
  for (int s = 0; s < 200; ++s) {
    const double tau = dist(rng);
    EXPECT_NEAR(TauFromDuration(DurationFromTau(tau)), tau, 1e-9 * std::max(1.0, std::abs(tau)));
    const double duration = std::exp(dist(rng) * 0.5);
    EXPECT_NEAR(DurationFromTau(TauFromDuration(duration)), duration, 1e-12 * duration);
  }
  EXPECT_NEAR(TauFromDuration(1.0), 0.0, 1e-15);
}

TEST(DurationMap, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> dist(-5.0, 5.0);
  for (int s = 0; s < 100; ++s) {
    const double tau = dist(rng);
    const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, tau);
    const Eigen::VectorXd fd =
        NumericalGradient([](const Eigen::VectorXd& v) { return DurationFromTau(v[0]); }, x, 1e-6);
    EXPECT_LT(std::abs(fd[0] - DurationGradient(tau)) / std::max(1.0, std::abs(fd[0])), 1e-5)
        << "tau " << tau;
  }
}

}  // namespace
}  // namespace strata
