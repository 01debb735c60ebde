#pragma once
/// Back end of the planner: a MINCO trajectory (Minco3) whose interior waypoints and piece
/// durations are optimised by L-BFGS (LBFGS++) over the paper's costs plus ground following.
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "strata/minco.hpp"
#include "strata/robot_profile.hpp"
#include "strata/status.hpp"
#include "strata/terrain_model.hpp"
#include "strata/trajectory_costs.hpp"

namespace strata {

/// Optimiser settings. Validate() names the first bad field.
struct OptimizerConfig {
  CostWeights weights;
  /// S' above this is penalised (s_thr) [-], >= 0. S' is the cone-diffused S, normalised to
  /// unit kernel sum, so this is a weighted mean of λ_f φ² + λ_m sqrt(‖∇H‖) nearby. On the
  /// shared maps the median S' over ramps is ~0.5 and the 90th percentile ~2.8 (their
  /// voxelised ramps are staircases), near the rim of valid ground it climbs to ~5.
  double safety_threshold = 1.5;
  /// ESDF distance below this is penalised (d_thr) [m], > 0. Keep it below the profile's
  /// reference height: the ground itself is an obstacle that far below the reference point.
  double distance_threshold_m = 0.15;
  /// Distance to the rim of traversable ground below which J_e penalises [m], >= 0; at most
  /// half a grid cell keeps the centres of rim cells free of penalty.
  double edge_margin_m = 0.1;
  /// The speed and acceleration bounds the optimiser aims for, as a fraction of the
  /// profile's, in (0, 1]: penalties are soft, so aiming a little low lands within them.
  double limit_margin = 0.92;
  /// Active-height robots: how far inside [h_min, h_max] and below the ceiling (less
  /// headroom) the optimiser keeps the body [m], >= 0. Like limit_margin, it lets the
  /// polynomial between constraint points stay within the verified range. Where a passage
  /// leaves less room than twice this, the margin shrinks to half the room. On the
  /// indoor_tables benchmark (2000 biped pairs) 0.02 m left 30 plans failing verification
  /// (the body a centimetre or two into the headroom or below h_min), 0.04 m 11.
  double body_height_margin_m = 0.04;
  /// Target length of one MINCO piece along the initial path [m], > 0.
  double piece_length_m = 1.5;
  /// Constraint points per piece κ (trapezoid over κ + 1 samples), >= 2.
  int samples_per_piece = 8;
  /// L-BFGS: most iterations per attempt, >= 1.
  int max_iterations = 200;
  /// L-BFGS: stop when ‖g‖ < epsilon · max(1, ‖x‖) (LBFGS++'s `epsilon`), > 0.
  double gradient_tolerance = 1e-5;
  /// L-BFGS: stop when the objective improves by less than this fraction over 3 iterations
  /// (LBFGS++'s `delta` with `past` = 3), >= 0.
  double relative_improvement_tolerance = 1e-3;
  /// L-BFGS: corrections kept (LBFGS++'s `m`), >= 1.
  int memory = 8;
  Status Validate() const;
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
