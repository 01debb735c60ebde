#include "strata/planning/minco.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>

namespace strata {
namespace {

constexpr int kCoeffs = Minco3::kPieceCoefficients;
// Both bandwidths of A(T) in the row order below (GCOPTER's): the widest rows are a joint's
// jerk/snap continuity (up to the next piece's c3/c4: upper 6) and its acceleration continuity
// (from this piece's c2: lower 6).
constexpr int kBandwidth = 6;

// Within joint i's six rows (starting at 6i + 3), the derivative order each row constrains at
// the end of piece i. Jerk and snap continuity come first so that every diagonal entry is a
// structural non-zero (6, 24, T⁵, −1, −1, −2): LU without pivoting then never meets a zero.
constexpr std::array<int, 6> kJointRowOrder = {3, 4, 0, 0, 1, 2};
// Offset within the joint block of the row p_i(T_i) = q_i (the others are continuity rows).
constexpr int kWaypointRow = 2;

// d^order/dt^order of t^k, for k = 0..5, at t: k!/(k−order)! t^(k−order).
std::array<double, kCoeffs> BasisDerivative(double t, int order) {
  std::array<double, kCoeffs> basis{};
  double power = 1.0;  // t^(k − order) by multiplication: std::pow showed in plan profiles.
  for (int k = order; k < kCoeffs; ++k) {
    basis[k] = kQuinticDerivativeFactor[order][k] * power;
    power *= t;
  }
  return basis;
}

}  // namespace

void BandedSystem::Reset(int n, int lower, int upper) {
  n_ = n;
  lower_ = lower;
  upper_ = upper;
  data_.assign(static_cast<std::size_t>(n) * (lower + upper + 1), 0.0);
  analyzed_ = false;
}

void BandedSystem::Clear() { std::fill(data_.begin(), data_.end(), 0.0); }

void BandedSystem::Analyze() {
  // Symbolic elimination: step k fills (i, j) wherever L(i, k) and U(k, j) are in the pattern.
  // The band holds every fill-in, because nothing is pivoted.
  std::vector<char> filled(data_.size());
  for (std::size_t e = 0; e < data_.size(); ++e) filled[e] = data_[e] != 0.0;
  const auto in = [&](int i, int j) { return filled[static_cast<std::size_t>(Index(i, j))] != 0; };
  for (int k = 0; k < n_; ++k) {
    for (int i = k + 1; i <= std::min(k + lower_, n_ - 1); ++i) {
      if (!in(i, k)) continue;
      for (int j = k + 1; j <= std::min(k + upper_, n_ - 1); ++j) {
        if (in(k, j)) filled[static_cast<std::size_t>(Index(i, j))] = 1;
      }
    }
  }
  for (Lists* lists : {&below_, &right_, &above_, &left_}) {
    lists->start.assign(1, 0);
    lists->entries.clear();
  }
  for (int k = 0; k < n_; ++k) {
    for (int i = k + 1; i <= std::min(k + lower_, n_ - 1); ++i) {
      if (in(i, k)) below_.entries.push_back({i, Index(i, k)});
    }
    for (int j = k + 1; j <= std::min(k + upper_, n_ - 1); ++j) {
      if (in(k, j)) right_.entries.push_back({j, Index(k, j)});
    }
    for (int i = std::max(0, k - upper_); i < k; ++i) {
      if (in(i, k)) above_.entries.push_back({i, Index(i, k)});
    }
    for (int j = std::max(0, k - lower_); j < k; ++j) {
      if (in(k, j)) left_.entries.push_back({j, Index(k, j)});
    }
    for (Lists* lists : {&below_, &right_, &above_, &left_}) {
      lists->start.push_back(static_cast<int>(lists->entries.size()));
    }
  }
  analyzed_ = true;
}

void BandedSystem::Factorize() {
  if (!analyzed_) Analyze();
  double* a = data_.data();
  for (int k = 0; k < n_; ++k) {
    const double pivot = a[Index(k, k)];
    const std::span<const Entry> column = below_[k];
    for (const Entry& l : column) a[l.index] /= pivot;
    for (const Entry& u : right_[k]) {
      // (i, j) lies this far from (i, k) in data_, whatever the row.
      const int offset = Index(0, u.other) - Index(0, k);
      const double u_kj = a[u.index];
      for (const Entry& l : column) a[l.index + offset] -= a[l.index] * u_kj;
    }
  }
}

namespace {

// The solves below combine whole rows of the right-hand side. On Eigen's column-major storage
// a row's entries are a column apart, so they work on a row-major copy, whose rows are
// contiguous, with the row length a compile-time constant for Strata's 3 and 4 dimensions:
// plan profiles showed the generic row operations costing about 3× as much.
using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The rows of a row-major right-hand side, `cols` entries each (a std::integral_constant for
// 3 and 4, so that the loops unroll).
template <typename Cols>
struct Rows {
  double* data;
  Cols cols;

  // Row i −= factor · row j.
  void Subtract(int i, int j, double factor) const {
    double* x_i = data + i * cols;
    const double* x_j = data + j * cols;
    for (Eigen::Index c = 0; c < cols; ++c) x_i[c] -= factor * x_j[c];
  }
  void Divide(int j, double divisor) const {
    double* x_j = data + j * cols;
    for (Eigen::Index c = 0; c < cols; ++c) x_j[c] /= divisor;
  }
};

// Calls f(rows) with the rows of *x.
template <typename F>
void WithRows(RowMajorMatrix* x, F&& f) {
  if (x->cols() == 3) {
    f(Rows<std::integral_constant<Eigen::Index, 3>>{x->data(), {}});
  } else if (x->cols() == 4) {
    f(Rows<std::integral_constant<Eigen::Index, 4>>{x->data(), {}});
  } else {
    f(Rows<Eigen::Index>{x->data(), x->cols()});
  }
}

}  // namespace

void BandedSystem::Solve(Eigen::MatrixXd* b) const {
  RowMajorMatrix x = *b;
  WithRows(&x, [&](const auto& rows) {
    for (int j = 0; j < n_; ++j) {  // L y = b, L unit lower.
      for (const Entry& l : below_[j]) rows.Subtract(l.other, j, data_[l.index]);
    }
    for (int j = n_ - 1; j >= 0; --j) {  // U x = y.
      rows.Divide(j, (*this)(j, j));
      for (const Entry& u : above_[j]) rows.Subtract(u.other, j, data_[u.index]);
    }
  });
  *b = x;
}

void BandedSystem::SolveTransposed(Eigen::MatrixXd* b) const {
  RowMajorMatrix x = *b;
  WithRows(&x, [&](const auto& rows) {
    for (int j = 0; j < n_; ++j) {  // Uᵀ z = b, Uᵀ lower.
      rows.Divide(j, (*this)(j, j));
      for (const Entry& u : right_[j]) rows.Subtract(u.other, j, data_[u.index]);
    }
    for (int j = n_ - 1; j >= 0; --j) {  // Lᵀ x = z, Lᵀ unit upper.
      for (const Entry& l : left_[j]) rows.Subtract(l.other, j, data_[l.index]);
    }
  });
  *b = x;
}

void Minco3::SetConditions(const Eigen::MatrixXd& head_pva, const Eigen::MatrixXd& tail_pva,
                           int piece_count) {
  dim_ = static_cast<int>(head_pva.rows());
  piece_count_ = piece_count;
  head_pva_ = head_pva;
  tail_pva_ = tail_pva;
  durations_ = Eigen::VectorXd::Ones(piece_count);
  coefficients_ = Eigen::MatrixXd::Zero(kCoeffs * piece_count, dim_);
  // A(T) is non-zero in the same entries for every T > 0 (its entries are factorials times
  // powers of T): the pattern of A(1) serves every SetParameters.
  system_.Reset(kCoeffs * piece_count, kBandwidth, kBandwidth);
  FillSystem(durations_);
  system_.Analyze();
}

void Minco3::FillSystem(const Eigen::VectorXd& durations) {
  const int m = piece_count_;
  const int n = kCoeffs * m;
  // Head: p, p', p'' of piece 0 at t = 0 are c0, c1, 2 c2.
  system_(0, 0) = 1.0;
  system_(1, 1) = 1.0;
  system_(2, 2) = 2.0;
  for (int i = 0; i + 1 < m; ++i) {
    const int row0 = kCoeffs * i + 3;
    const int col = kCoeffs * i;
    const int next_col = col + kCoeffs;
    for (int r = 0; r < kCoeffs; ++r) {
      const int order = kJointRowOrder[r];
      const std::array<double, kCoeffs> basis = BasisDerivative(durations[i], order);
      for (int k = order; k < kCoeffs; ++k) system_(row0 + r, col + k) = basis[k];
      if (r != kWaypointRow) {
        // −p_{i+1}^{(order)}(0) = −order! · c_{i+1, order}.
        system_(row0 + r, next_col + order) = -BasisDerivative(0.0, order)[order];
      }
    }
  }
  // Tail: p, p', p'' of the last piece at its end.
  const int last_col = kCoeffs * (m - 1);
  for (int order = 0; order < 3; ++order) {
    const std::array<double, kCoeffs> basis = BasisDerivative(durations[m - 1], order);
    for (int k = order; k < kCoeffs; ++k) system_(n - 3 + order, last_col + k) = basis[k];
  }
}

void Minco3::SetParameters(const Eigen::MatrixXd& waypoints, const Eigen::VectorXd& durations) {
  const int m = piece_count_;
  const int n = kCoeffs * m;
  durations_ = durations;
  system_.Clear();
  FillSystem(durations_);
  // b: the head and tail states, the waypoints in their joints' waypoint rows, 0 elsewhere.
  Eigen::MatrixXd& b = coefficients_;
  b.setZero(n, dim_);
  b.topRows(3) = head_pva_.transpose();
  for (int i = 0; i + 1 < m; ++i) {
    b.row(kCoeffs * i + 3 + kWaypointRow) = waypoints.col(i).transpose();
  }
  b.bottomRows(3) = tail_pva_.transpose();

  system_.Factorize();
  system_.Solve(&coefficients_);
}

int Minco3::LocatePiece(double t, double* local_t) const {
  t = std::max(t, 0.0);
  int piece = 0;
  while (piece + 1 < piece_count_ && t > durations_[piece]) {
    t -= durations_[piece];
    ++piece;
  }
  *local_t = std::min(t, durations_[piece]);
  return piece;
}

Eigen::VectorXd Minco3::PieceDerivative(int piece, double t, int order) const {
  const std::array<double, kCoeffs> basis = BasisDerivative(t, order);
  const Eigen::Map<const Eigen::Matrix<double, kCoeffs, 1>> beta(basis.data());
  return coefficients_.middleRows<kCoeffs>(kCoeffs * piece).transpose() * beta;
}

Eigen::VectorXd Minco3::Evaluate(double t, int order) const {
  double local_t = 0.0;
  const int piece = LocatePiece(t, &local_t);
  return PieceDerivative(piece, local_t, order);
}

double Minco3::JerkEnergy(Eigen::MatrixXd* grad_c, Eigen::VectorXd* grad_T) const {
  const int m = piece_count_;
  if (grad_c != nullptr && (grad_c->rows() != kCoeffs * m || grad_c->cols() != dim_)) {
    grad_c->setZero(kCoeffs * m, dim_);
  }
  if (grad_T != nullptr && grad_T->size() != m) grad_T->setZero(m);

  double energy = 0.0;
  for (int i = 0; i < m; ++i) {
    const double t1 = durations_[i];
    const double t2 = t1 * t1;
    const double t3 = t2 * t1;
    const double t4 = t3 * t1;
    const double t5 = t4 * t1;
    const auto c3 = coefficients_.row(kCoeffs * i + 3);
    const auto c4 = coefficients_.row(kCoeffs * i + 4);
    const auto c5 = coefficients_.row(kCoeffs * i + 5);
    const double c33 = c3.squaredNorm();
    const double c34 = c3.dot(c4);
    const double c44 = c4.squaredNorm();
    const double c35 = c3.dot(c5);
    const double c45 = c4.dot(c5);
    const double c55 = c5.squaredNorm();
    // ∫₀ᵀ ‖6c₃ + 24c₄t + 60c₅t²‖² dt (docs/design.md §11, J_m).
    energy += 36.0 * c33 * t1 + 144.0 * c34 * t2 + 192.0 * c44 * t3 + 240.0 * c35 * t3 +
              720.0 * c45 * t4 + 720.0 * c55 * t5;
    if (grad_c != nullptr) {
      grad_c->row(kCoeffs * i + 3) += 72.0 * t1 * c3 + 144.0 * t2 * c4 + 240.0 * t3 * c5;
      grad_c->row(kCoeffs * i + 4) += 144.0 * t2 * c3 + 384.0 * t3 * c4 + 720.0 * t4 * c5;
      grad_c->row(kCoeffs * i + 5) += 240.0 * t3 * c3 + 720.0 * t4 * c4 + 1440.0 * t5 * c5;
    }
    if (grad_T != nullptr) {
      // d/dT ∫₀ᵀ ‖jerk‖² = ‖jerk(T)‖².
      (*grad_T)[i] += 36.0 * c33 + 288.0 * c34 * t1 + 576.0 * c44 * t2 + 720.0 * c35 * t2 +
                      2880.0 * c45 * t3 + 3600.0 * c55 * t4;
    }
  }
  return energy;
}

void Minco3::PropagateGradient(const Eigen::MatrixXd& grad_c, const Eigen::VectorXd& grad_T,
                               Eigen::MatrixXd* grad_waypoints,
                               Eigen::VectorXd* grad_durations) const {
  const int m = piece_count_;
  const int n = kCoeffs * m;
  // A c = b(q) gives dc = A⁻¹(db − dA·c), so dJ = Gᵀ(db − dA·c) with Aᵀ G = ∂J/∂c.
  Eigen::MatrixXd adjoint = grad_c;
  system_.SolveTransposed(&adjoint);

  grad_waypoints->resize(dim_, m - 1);
  *grad_durations = grad_T;
  // adjoint row · p_piece^{(order)}(T_piece), without PieceDerivative's allocation: this runs
  // for every row of A(T) in every evaluation.
  const auto adjoint_dot_derivative = [&](int row, int piece, int order) {
    const std::array<double, kCoeffs> basis = BasisDerivative(durations_[piece], order);
    double sum = 0.0;
    for (int a = 0; a < dim_; ++a) {
      double derivative = 0.0;
      for (int k = 0; k < kCoeffs; ++k) {
        derivative += coefficients_(kCoeffs * piece + k, a) * basis[k];
      }
      sum += adjoint(row, a) * derivative;
    }
    return sum;
  };
  for (int i = 0; i + 1 < m; ++i) {
    const int row0 = kCoeffs * i + 3;
    grad_waypoints->col(i) = adjoint.row(row0 + kWaypointRow).transpose();
    // Joint i's rows hold p_i^{(order)}(T_i), whose T-derivative is p_i^{(order+1)}(T_i).
    for (int r = 0; r < kCoeffs; ++r) {
      (*grad_durations)[i] -= adjoint_dot_derivative(row0 + r, i, kJointRowOrder[r] + 1);
    }
  }
  for (int order = 0; order < 3; ++order) {
    (*grad_durations)[m - 1] -= adjoint_dot_derivative(n - 3 + order, m - 1, order + 1);
  }
}

double DurationFromTau(double tau) {
  if (tau > 0.0) return (0.5 * tau + 1.0) * tau + 1.0;
  return 1.0 / ((0.5 * tau - 1.0) * tau + 1.0);
}

double TauFromDuration(double duration) {
  if (duration > 1.0) return std::sqrt(2.0 * duration - 1.0) - 1.0;
  return 1.0 - std::sqrt(2.0 / duration - 1.0);
}

double DurationGradient(double tau) {
  if (tau > 0.0) return tau + 1.0;
  const double denominator = (0.5 * tau - 1.0) * tau + 1.0;
  return (1.0 - tau) / (denominator * denominator);
}

}  // namespace strata
