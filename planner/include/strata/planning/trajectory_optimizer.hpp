#pragma once
/// Back end of the planner: a MINCO trajectory (Minco3) whose interior waypoints and piece
/// durations are optimised by L-BFGS (LBFGS++) over the paper's costs plus ground following.
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/minco.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/planning/trajectory_costs.hpp"
#include "strata/status.hpp"

namespace strata {

/// Optimiser settings. Validate() blames the first bad field by its path, `path`.<field>.
struct OptimizerConfig {
  CostWeights weights;  ///< λ of each cost term.
  CostConfig cost;      ///< Thresholds and margins of the cost terms, constraint points.
  /// Target length of one MINCO piece along the initial path [m], > 0.
  double piece_length_m = 1.5;
  /// Cruise speed of the initial timing, as a fraction of the profile's speed bounds, in
  /// (0, 1] (MakeInitialProblem: a trapezoid at half the acceleration bounds). The optimiser
  /// rarely slows a trajectory down or speeds it up by much, so faster starts end faster
  /// (docs/benchmarks.md, "Why the planner's defaults").
  double initial_speed_fraction = 0.96;
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
  /// Columns of initial_waypoints, ascending, whose position rows (x, y, z) the optimiser
  /// keeps exactly where they are: a route's flow-through vias (PlanRequest::via). Their
  /// gradient is zeroed, so L-BFGS, which starts there, never moves them; a 4th row (body
  /// height) stays free.
  std::vector<int> pinned_waypoints;
  /// Columns of initial_waypoints, ascending, that the optimiser holds in place as it does
  /// pinned ones (the 4th row free too), without being vias: the points that split the piece
  /// next to an end at rest (MakeInitialProblem), so that the trajectory leaves and reaches
  /// rest along the path.
  std::vector<int> held_waypoints;
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
/// ~piece_length_m of arc length (and halfway along the piece next to an end at rest, held:
/// held_waypoints), durations from the profile's speed bounds, body height from the ceiling
/// clearance for active-height robots. The path has at least 2 points. `pinned`:
/// indices of interior path points (ascending, in (0, size − 1)) that become waypoints exactly
/// (as corners do) and are pinned there (OptimizationProblem::pinned_waypoints, in the same
/// order).
OptimizationProblem MakeInitialProblem(const TrajectoryCost& cost,
                                       const std::vector<Eigen::Vector3d>& path_m,
                                       const RobotState& start, const RobotState& goal,
                                       const OptimizerConfig& config,
                                       std::span<const std::size_t> pinned = {});

/// The last resort when no optimised trajectory passes verification: a minimum-jerk
/// trajectory through every point of `path_m` (start and goal in place of its ends) and points
/// every third of a cell between them, all on the ground interpolated between columns (the
/// verifier's), timed slowly (a trapezoid at 40% of the speed bounds and 25% of the
/// acceleration bounds, slower at corners), not optimised. Points that close keep it on the
/// ground and inside the corridor the path was found in; what is too fast for the bounds is
/// then stretched in time. A point nearer to an obstacle than `min_obstacle_distance_m` (the
/// verifier's, VerifierConfig) and a margin is raised by up to 5 cm where that clears it (the
/// interpolated ground passing under a step's edge). Body height (active-height robots): the
/// suitable height, crouching up to 0.5 m ahead of a ceiling and ramping between heights
/// instead of stepping, start and goal included. `pinned` as for MakeInitialProblem (every
/// path point is a waypoint here; pinned_waypoints says which columns they are; pinned points
/// stay where they are).
OptimizationProblem MakeFallbackProblem(const TrajectoryCost& cost,
                                        const std::vector<Eigen::Vector3d>& path_m,
                                        const RobotState& start, const RobotState& goal,
                                        double min_obstacle_distance_m,
                                        std::span<const std::size_t> pinned = {});

/// A trajectory the robot is following, to replan from (PlanRequest::warm_start): the
/// optimiser starts from its remainder instead of a searched path.
struct WarmStart {
  /// The trajectory as a previous plan returned it (its dimension the profile's).
  Trajectory trajectory;
  /// Time on `trajectory` at which the robot is at the request's start [s]; < 0: the time
  /// whose position is nearest the start.
  double elapsed_s = -1;
};

/// How far the start and the goal of a replan may lie from the warm start's trajectory (at
/// the time the robot is on it, and at its end) for its remainder to be the initial guess [m].
inline constexpr double kWarmStartToleranceM = 0.5;

/// The problem of continuing along the remainder of `warm.trajectory`: its joints and piece
/// durations after the robot's time on it (a stub of the current piece merged with the
/// next), from `start` to `goal`. Fails with kInvalidInput when the trajectory's dimension is
/// not the profile's or start or goal lies more than kWarmStartToleranceM from it.
Expected<OptimizationProblem> MakeWarmProblem(const TrajectoryCost& cost, const WarmStart& warm,
                                              const RobotState& start, const RobotState& goal);

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
