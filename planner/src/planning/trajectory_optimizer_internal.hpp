#pragma once
// The objective L-BFGS minimises in OptimizeTrajectory, exposed for its tests; not installed.

#include <functional>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "strata/planning/minco.hpp"
#include "strata/planning/trajectory_costs.hpp"
#include "strata/planning/trajectory_optimizer.hpp"

namespace strata::internal {

// Thrown from inside the L-BFGS objective when should_stop fires; LBFGS++ has no other way
// to stop early. Caught in OptimizeTrajectory, never crosses the library's API.
struct StopRequested {};

// The objective over x = [waypoints (dim×(M−1), column-major), τ (M)] in LBFGS++'s shape:
// J(q, T(τ)) of `cost` and its gradient, T = DurationFromTau(τ). `minco` has had SetConditions
// and is left holding the trajectory of the last x evaluated. Remembers the best point
// evaluated, because LBFGS++ may throw from a failed line search. The position rows (x, y, z)
// of the `pinned` waypoint columns get a zero gradient: L-BFGS's steps are combinations of
// gradients, so it never moves them from where it starts.
class OptimizerObjective {
 public:
  OptimizerObjective(const TrajectoryCost& cost, Minco3* minco,
                     const std::function<bool()>& should_stop, std::span<const int> pinned = {})
      : cost_(cost),
        minco_(minco),
        should_stop_(should_stop),
        pinned_(pinned.begin(), pinned.end()) {
    const int pieces = minco->piece_count();
    waypoints_.resize(minco->dim(), pieces - 1);
    durations_.resize(pieces);
  }

  double operator()(const Eigen::VectorXd& x, Eigen::VectorXd& grad) {
    if (should_stop_ && should_stop_()) throw StopRequested{};
    ++evaluations_;
    const int pieces = minco_->piece_count();
    const int waypoint_values = static_cast<int>(waypoints_.size());
    Apply(x);
    const double value = cost_.Evaluate(*minco_, &grad_c_, &grad_T_, nullptr, &terrain_memo_);
    minco_->PropagateGradient(grad_c_, grad_T_, &grad_waypoints_, &grad_durations_);
    grad.resize(x.size());
    grad.head(waypoint_values) =
        Eigen::Map<const Eigen::VectorXd>(grad_waypoints_.data(), waypoint_values);
    for (const int column : pinned_)
      grad.segment(Eigen::Index{column} * minco_->dim(), 3).setZero();
    for (int i = 0; i < pieces; ++i) {
      grad(waypoint_values + i) = grad_durations_(i) * DurationGradient(x(waypoint_values + i));
    }
    if (std::isfinite(value) && value < best_value_) {
      best_value_ = value;
      best_x_ = x;
    }
    return value;
  }

  // Sets *minco to the trajectory of x.
  void Apply(const Eigen::VectorXd& x) {
    const int waypoint_values = static_cast<int>(waypoints_.size());
    waypoints_ = Eigen::Map<const Eigen::MatrixXd>(x.data(), waypoints_.rows(), waypoints_.cols());
    for (int i = 0; i < minco_->piece_count(); ++i) {
      durations_(i) = DurationFromTau(x(waypoint_values + i));
    }
    minco_->SetParameters(waypoints_, durations_);
  }

  const Eigen::VectorXd& best_x() const { return best_x_; }
  double best_value() const { return best_value_; }
  int evaluations() const { return evaluations_; }

 private:
  const TrajectoryCost& cost_;
  Minco3* minco_;
  std::function<bool()> should_stop_;
  std::vector<int> pinned_;
  Eigen::MatrixXd waypoints_, grad_c_, grad_waypoints_;
  Eigen::VectorXd durations_, grad_T_, grad_durations_;
  Eigen::VectorXd best_x_;
  TerrainMemo terrain_memo_;  // Carried from one evaluation to the next.
  double best_value_ = std::numeric_limits<double>::infinity();
  int evaluations_ = 0;
};

/// The decision vector x = [waypoints (dim×(M−1), column-major), τ (M)] of `problem`'s
/// initial guess, τ_i = TauFromDuration(T_i).
inline Eigen::VectorXd InitialDecisionVector(const OptimizationProblem& problem) {
  const auto waypoint_values = problem.initial_waypoints.size();
  const auto pieces = problem.initial_durations.size();
  Eigen::VectorXd x(waypoint_values + pieces);
  x.head(waypoint_values) =
      Eigen::Map<const Eigen::VectorXd>(problem.initial_waypoints.data(), waypoint_values);
  for (Eigen::Index i = 0; i < pieces; ++i) {
    x(waypoint_values + i) = TauFromDuration(problem.initial_durations(i));
  }
  return x;
}

}  // namespace strata::internal
