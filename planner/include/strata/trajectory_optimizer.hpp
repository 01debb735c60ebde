#pragma once
/// Back end of the planner: a MINCO trajectory (Minco3) whose interior waypoints and piece
/// durations are optimised by L-BFGS (LBFGS++) over the paper's costs plus ground following.
#include <functional>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/minco.hpp"
#include "strata/robot_profile.hpp"
#include "strata/status.hpp"
#include "strata/terrain_model.hpp"
#include "strata/trajectory_costs.hpp"

namespace strata {

/// Optimiser settings. Validate() blames the first bad field by its path, `path`.<field>.
struct OptimizerConfig {
  CostWeights weights;  ///< λ of each cost term.
  CostConfig cost;      ///< Thresholds and margins of the cost terms, constraint points.
  /// Target length of one MINCO piece along the initial path [m], > 0.
  double piece_length_m = 1.5;
  /// L-BFGS: most iterations per attempt, >= 1.
  int max_iterations = 200;
  /// L-BFGS: stop when ‖g‖ < epsilon · max(1, ‖x‖) (LBFGS++'s `epsilon`), > 0.
  double gradient_tolerance = 1e-5;
  /// L-BFGS: stop when the objective improves by less than this fraction over 3 iterations
  /// (LBFGS++'s `delta` with `past` = 3), >= 0.
  double relative_improvement_tolerance = 1e-3;
  /// L-BFGS: corrections kept (LBFGS++'s `m`), >= 1.
  int memory = 8;
  Status Validate(std::string_view path = "optimizer") const;
};

/// The trajectory optimisation problem of one plan.
struct OptimizationProblem {
  /// Start and end states, dim×3 (position, velocity, acceleration columns); dim is 3, or 4
  /// for active-height robots (row 3: body height and its derivatives).
  Eigen::MatrixXd head_pva;
  Eigen::MatrixXd tail_pva;
  /// Initial interior waypoints (dim×(M−1)) and durations (M, each > 0).
  Eigen::MatrixXd initial_waypoints;
  Eigen::VectorXd initial_durations;
};

/// How an optimisation ended.
struct OptimizationReport {
  int iterations = 0;   ///< L-BFGS iterations.
  int evaluations = 0;  ///< Objective evaluations.
  double initial_cost = 0;
  double final_cost = 0;
  CostBreakdown final_terms;  ///< The final cost split by term.
  /// True when L-BFGS met a tolerance; false when it ran out of iterations or its line
  /// search gave up (the best point seen is still returned).
  bool converged = false;
};

/// Builds the problem from a searched path (reference points, start to goal): waypoints every
/// ~piece_length_m of arc length, durations from the profile's speed bounds, body height from
/// the ceiling clearance for active-height robots. The path has at least 2 points.
OptimizationProblem MakeInitialProblem(const TrajectoryCost& cost,
                                       const std::vector<Eigen::Vector3d>& path_m,
                                       const RobotState& start, const RobotState& goal,
                                       const OptimizerConfig& config);

/// Minimises the cost over waypoints and durations (τ per piece through DurationFromTau).
/// Writes the optimised trajectory into *minco (SetConditions and SetParameters done).
/// Fails with kCancelled when should_stop returns true (polled at every evaluation); the
/// iteration budget is not a failure (see OptimizationReport::converged).
Expected<OptimizationReport> OptimizeTrajectory(const TrajectoryCost& cost,
                                                const OptimizationProblem& problem,
                                                const OptimizerConfig& config,
                                                const std::function<bool()>& should_stop,
                                                Minco3* minco);

}  // namespace strata
