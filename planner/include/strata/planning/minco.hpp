#pragma once
/// Minimum-jerk MINCO trajectories (s = 3): Wang et al., "Geometrically constrained trajectory
/// optimization for multicopters", T-RO 2022. M quintic pieces with fixed head and tail
/// position, velocity and acceleration, interior waypoints q_1..q_{M−1} and C⁴ continuity at
/// the joints. The coefficients c = M(q, T) solve a banded system A(T) c = b(q) in O(M); the
/// gradient of any cost J(c, T) maps to (q, T) by one solve with Aᵀ (the adjoint), also O(M).
///
/// Usage (GCOPTER's forward/backward shape):
///   Minco3 minco;
///   minco.SetConditions(head_pva, tail_pva, piece_count);
///   minco.SetParameters(waypoints, durations);                // forward: c = M(q, T)
///   Eigen::MatrixXd grad_c; Eigen::VectorXd grad_T;           // zero-sized: set to zero
///   double cost = minco.JerkEnergy(&grad_c, &grad_T);         // each cost *adds* dJ/dc, dJ/dT
///   minco.PropagateGradient(grad_c, grad_T, &grad_q, &grad_durations);  // backward
///
/// All inputs are preconditions (this is the optimiser's inner loop): finite values, shapes as
/// documented, durations > 0, piece_count >= 1. Validate user input before it reaches here.

#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace strata {

/// kQuinticDerivativeFactor[order][k] = k!/(k − order)!: what the order-th derivative of t^k
/// multiplies t^(k − order) by, for k and order in [0, 5] (0 where k < order).
inline constexpr std::array<std::array<double, 6>, 6> kQuinticDerivativeFactor = [] {
  std::array<std::array<double, 6>, 6> factor{};
  for (int order = 0; order < 6; ++order) {
    for (int k = order; k < 6; ++k) {
      double f = 1;
      for (int m = k - order + 1; m <= k; ++m) f *= m;
      factor[order][k] = f;
    }
  }
  return factor;
}();

/// A square banded matrix with lower bandwidth `lower` and upper bandwidth `upper`, stored by
/// diagonals (O(n·(lower + upper + 1)) memory), factorised in place by LU without pivoting.
/// No pivoting is safe for the MINCO system in the row order Minco3 uses (as in GCOPTER);
/// it is not a general-purpose solver. Exposed for tests.
///
/// The factorisation and the solves visit only the entries of a recorded pattern (Analyze):
/// MINCO's A(T) has about 6 of the 13 entries of its band per row, and its factors keep
/// about 6 too, so the dense band loops spent most of MINCO's forward pass on zeros.
class BandedSystem {
 public:
  /// Resizes to n×n with the given bandwidths, sets every entry to zero and forgets the
  /// pattern. n >= 1.
  void Reset(int n, int lower, int upper);
  /// Sets every entry to zero, keeping the size and the pattern: for a matrix that is non-zero
  /// only where the analysed one was.
  void Clear();
  /// Entry (row, col); precondition: −lower <= col − row <= upper.
  double& operator()(int row, int col) { return data_[Index(row, col)]; }
  double operator()(int row, int col) const { return data_[Index(row, col)]; }
  /// Records the pattern of the LU factors: the entries non-zero now, and those elimination
  /// fills in from them.
  void Analyze();
  /// Replaces the matrix by its LU factors (unit lower L, upper U), in O(n·lower·upper);
  /// analyses first if no pattern is recorded.
  void Factorize();
  /// Solves A X = B in place (B has n rows, any number of columns); after Factorize().
  void Solve(Eigen::MatrixXd* b) const;
  /// Solves Aᵀ X = B in place with the same factors; after Factorize().
  void SolveTransposed(Eigen::MatrixXd* b) const;
  int size() const { return n_; }

 private:
  int Index(int row, int col) const { return (row - col + upper_) * n_ + col; }

  // An entry of the pattern, seen from row or column k: the other coordinate (its column or
  // its row) and its place in data_.
  struct Entry {
    int other;
    int index;
  };
  // For each k, some entries of row or column k in the pattern, in ascending `other`.
  struct Lists {
    std::vector<int> start;  // n + 1 offsets into entries.
    std::vector<Entry> entries;
    std::span<const Entry> operator[](int k) const {
      return {entries.data() + start[k], entries.data() + start[k + 1]};
    }
  };

  int n_ = 0;
  int lower_ = 0;
  int upper_ = 0;
  std::vector<double> data_;
  bool analyzed_ = false;
  Lists below_;  // Rows i > k with L(i, k) in the pattern.
  Lists right_;  // Columns j > k with U(k, j) in the pattern.
  Lists above_;  // Rows i < k with U(i, k) in the pattern.
  Lists left_;   // Columns j < k with L(k, j) in the pattern.
};

/// A minimum-jerk piecewise-quintic trajectory in `dim` dimensions (3: x, y, z; 4 adds body
/// height), parameterised by interior waypoints and per-piece durations.
class Minco3 {
 public:
  /// Coefficients per piece (quintic).
  static constexpr int kPieceCoefficients = 6;

  /// Fixes the boundary states and the number of pieces, and sizes every buffer.
  /// head_pva, tail_pva: dim×3, columns are position [m], velocity [m/s], acceleration
  /// [m/s²]; dim = head_pva.rows() (>= 1; 3 or 4 in Strata). piece_count M >= 1.
  void SetConditions(const Eigen::MatrixXd& head_pva, const Eigen::MatrixXd& tail_pva,
                     int piece_count);

  /// Forward pass: builds A(T) c = b and solves it (banded LU, O(M)); keeps the factors for
  /// PropagateGradient. waypoints: dim×(M−1), column i is the joint between pieces i and i+1
  /// [m]; durations: M entries [s], each > 0. After SetConditions().
  void SetParameters(const Eigen::MatrixXd& waypoints, const Eigen::VectorXd& durations);

  /// Coefficients, 6M×dim: piece i is rows 6i..6i+5, lowest order first, so
  /// p_i(t) = Σ_k c(6i+k, :) t^k for local time t ∈ [0, T_i].
  const Eigen::MatrixXd& coefficients() const { return coefficients_; }
  /// Piece durations [s], M entries.
  const Eigen::VectorXd& durations() const { return durations_; }
  int piece_count() const { return piece_count_; }
  int dim() const { return dim_; }
  /// The boundary states SetConditions fixed (dim×3: position, velocity, acceleration).
  const Eigen::MatrixXd& head_pva() const { return head_pva_; }
  const Eigen::MatrixXd& tail_pva() const { return tail_pva_; }
  /// Σ T_i [s].
  double TotalDuration() const { return durations_.sum(); }

  /// State at global time t [s] from the start, t clamped to [0, TotalDuration()].
  Eigen::VectorXd Position(double t) const { return Evaluate(t, 0); }
  Eigen::VectorXd Velocity(double t) const { return Evaluate(t, 1); }
  Eigen::VectorXd Acceleration(double t) const { return Evaluate(t, 2); }
  Eigen::VectorXd Jerk(double t) const { return Evaluate(t, 3); }
  /// The `order`-th time derivative (0..5) at global time t (clamped as above).
  Eigen::VectorXd Evaluate(double t, int order) const;

  /// Smoothness cost J_m = Σ_i ∫₀^{T_i} ‖jerk‖² dt in closed form [m²/s⁵]. ADDS dJ/dc
  /// (6M×dim) into *grad_c and ∂J/∂T (M) into *grad_T; either may be null. An accumulator
  /// whose shape does not match is first resized and zeroed.
  double JerkEnergy(Eigen::MatrixXd* grad_c, Eigen::VectorXd* grad_T) const;

  /// Backward pass (adjoint): given ∂J/∂c (6M×dim) and the explicit ∂J/∂T (M) of a cost
  /// J(c, T), writes the total derivatives of J(M(q, T), T): *grad_waypoints (dim×(M−1)) and
  /// *grad_durations (M), overwriting them. One banded solve with Aᵀ; after SetParameters().
  void PropagateGradient(const Eigen::MatrixXd& grad_c, const Eigen::VectorXd& grad_T,
                         Eigen::MatrixXd* grad_waypoints, Eigen::VectorXd* grad_durations) const;

 private:
  // Locates global time t: returns the piece index and writes the local time.
  int LocatePiece(double t, double* local_t) const;
  // The `order`-th derivative of piece i at local time t.
  Eigen::VectorXd PieceDerivative(int piece, double t, int order) const;
  // Writes A(durations) into system_, which holds zeros (Reset or Clear).
  void FillSystem(const Eigen::VectorXd& durations);

  int dim_ = 0;
  int piece_count_ = 0;
  Eigen::MatrixXd head_pva_;
  Eigen::MatrixXd tail_pva_;
  Eigen::VectorXd durations_;
  Eigen::MatrixXd coefficients_;
  BandedSystem system_;  // LU factors of A(T) after SetParameters().
};

/// Smooth positive duration map used so the optimiser runs unconstrained (one τ per piece):
/// T = ½τ² + τ + 1 for τ > 0, T = 1/(½τ² − τ + 1) for τ <= 0. C² at τ = 0 (T = T' = T'' = 1),
/// strictly increasing, T → 0 as τ → −∞. Returns T [s] > 0.
double DurationFromTau(double tau);
/// Inverse of DurationFromTau; T > 0.
double TauFromDuration(double duration);
/// dT/dτ of DurationFromTau at τ (> 0 everywhere).
double DurationGradient(double tau);

}  // namespace strata
