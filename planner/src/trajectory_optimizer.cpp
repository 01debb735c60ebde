#include "strata/trajectory_optimizer.hpp"

#include <LBFGS.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

#include "format_internal.hpp"
#include "strata/terrain_query.hpp"
#include "trajectory_optimizer_internal.hpp"

namespace strata {
namespace {

// L-BFGS runs per optimisation at most (see the restart loop).
constexpr int kMaxRestarts = 8;

// Positions every `spacing_m` of arc length along the polyline, excluding both ends.
std::vector<Eigen::Vector3d> ResampleInterior(const std::vector<Eigen::Vector3d>& path,
                                              double spacing_m, int* pieces) {
  double length = 0;
  for (std::size_t k = 1; k < path.size(); ++k) length += (path[k] - path[k - 1]).norm();
  *pieces = std::max(1, static_cast<int>(std::lround(length / spacing_m)));
  const double step = length / *pieces;
  std::vector<Eigen::Vector3d> points;
  double travelled = 0;
  double next = step;
  for (std::size_t k = 1; k < path.size() && static_cast<int>(points.size()) < *pieces - 1; ++k) {
    const double segment = (path[k] - path[k - 1]).norm();
    while (segment > 0 && travelled + segment >= next &&
           static_cast<int>(points.size()) < *pieces - 1) {
      points.emplace_back(path[k - 1] + (next - travelled) / segment * (path[k] - path[k - 1]));
      next += step;
    }
    travelled += segment;
  }
  while (static_cast<int>(points.size()) < *pieces - 1) points.push_back(path.back());
  return points;
}

}  // namespace

Status OptimizerConfig::Validate(std::string_view path) const {
  if (Status s = weights.Validate(internal::FieldPath(path, "weights")); !s) return s;
  const auto bad_field = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (Status s = cost.Validate(internal::FieldPath(path, "cost")); !s) return s;
  if (!(std::isfinite(piece_length_m) && piece_length_m > 0)) {
    return bad_field("piece_length_m", piece_length_m, "> 0 and finite");
  }
  if (max_iterations < 1) return bad_field("max_iterations", max_iterations, ">= 1");
  if (!(std::isfinite(gradient_tolerance) && gradient_tolerance > 0)) {
    return bad_field("gradient_tolerance", gradient_tolerance, "> 0 and finite");
  }
  if (!(std::isfinite(relative_improvement_tolerance) && relative_improvement_tolerance >= 0)) {
    return bad_field("relative_improvement_tolerance", relative_improvement_tolerance,
                     ">= 0 and finite");
  }
  if (memory < 1) return bad_field("memory", memory, ">= 1");
  return Status::Ok();
}

OptimizationProblem MakeInitialProblem(const TrajectoryCost& cost,
                                       const std::vector<Eigen::Vector3d>& path_m,
                                       const RobotState& start, const RobotState& goal,
                                       const OptimizerConfig& config) {
  const CostParams& params = cost.params();
  const int dim = params.dim();
  const double reference_height_m = params.profile.reference_height_m;
  int pieces = 1;
  const std::vector<Eigen::Vector3d> interior =
      ResampleInterior(path_m, config.piece_length_m, &pieces);

  // Body height (active robots): the suitable height where the robot stands.
  const auto body_height = [&](const Eigen::Vector3d& p) {
    GroundSample ground;
    const double clearance =
        SampleGround(cost.model(), p, reference_height_m, cost.ClearanceCap(), &ground)
            ? ground.clearance_m
            : cost.ClearanceCap();
    return cost.SuitableBodyHeight(clearance, nullptr);
  };
  const auto boundary = [&](const RobotState& state) {
    Eigen::MatrixXd pva = Eigen::MatrixXd::Zero(dim, 3);
    pva.col(0).head<3>() = state.position_m;
    pva.col(1).head<3>() = state.velocity_mps;
    pva.col(2).head<3>() = state.acceleration_mps2;
    if (dim == 4) pva(3, 0) = body_height(state.position_m);
    return pva;
  };

  OptimizationProblem problem;
  problem.head_pva = boundary(start);
  problem.tail_pva = boundary(goal);
  problem.initial_waypoints.resize(dim, pieces - 1);
  for (int k = 0; k < pieces - 1; ++k) {
    problem.initial_waypoints.col(k).head<3>() = interior[static_cast<std::size_t>(k)];
    if (dim == 4)
      problem.initial_waypoints(3, k) = body_height(interior[static_cast<std::size_t>(k)]);
  }
  // Durations at a comfortable fraction of the speed bounds; the optimiser shortens them.
  problem.initial_durations.resize(pieces);
  Eigen::Vector3d previous = start.position_m;
  for (int k = 0; k < pieces; ++k) {
    const Eigen::Vector3d next =
        k + 1 < pieces ? interior[static_cast<std::size_t>(k)] : goal.position_m;
    const Eigen::Vector3d delta = next - previous;
    const double horizontal = delta.head<2>().norm() / (0.5 * params.max_speed_horizontal_mps());
    const double vertical = std::abs(delta.z()) / (0.5 * params.max_speed_vertical_mps());
    problem.initial_durations(k) = std::max({horizontal, vertical, 0.1});
    previous = next;
  }
  return problem;
}

Expected<OptimizationReport> OptimizeTrajectory(const TrajectoryCost& cost,
                                                const OptimizationProblem& problem,
                                                const OptimizerConfig& config,
                                                const std::function<bool()>& should_stop,
                                                Minco3* minco) {
  if (Status s = config.Validate(); !s) return s.error();
  const int pieces = static_cast<int>(problem.initial_durations.size());
  minco->SetConditions(problem.head_pva, problem.tail_pva, pieces);

  Eigen::VectorXd x = internal::InitialDecisionVector(problem);

  LBFGSpp::LBFGSParam<double> param;
  param.m = config.memory;
  param.epsilon = config.gradient_tolerance;
  param.epsilon_rel = config.gradient_tolerance;
  param.past = 3;
  param.delta = config.relative_improvement_tolerance;
  param.max_linesearch = 32;
  // Backtracking to the (weak) Wolfe conditions: about one evaluation per iteration here, and
  // the curvature condition keeps the L-BFGS update positive definite.
  param.linesearch = LBFGSpp::LBFGS_LINESEARCH_BACKTRACKING_WOLFE;

  internal::OptimizerObjective objective(cost, minco, should_stop);
  OptimizationReport report;
  Eigen::VectorXd scratch;
  try {
    report.initial_cost = objective(x, scratch);
    // A line search that cannot meet the Wolfe conditions (a cliff of a cubic penalty from a
    // poor start) ends an L-BFGS run by an exception; restarting from the best point with a
    // fresh memory gets past it. Restarts stop when one makes no progress.
    double previous_best = objective.best_value();
    int iterations_left = config.max_iterations;
    for (int run = 0; run < kMaxRestarts && iterations_left > 0; ++run) {
      param.max_iterations = iterations_left;
      LBFGSpp::LBFGSSolver<double, LBFGSpp::LineSearchBacktracking> solver(param);
      x = objective.best_x();
      double value = 0;
      try {
        const int iterations = solver.minimize(objective, x, value);
        report.iterations += iterations;
        report.converged = iterations < iterations_left;
        break;
      } catch (const internal::StopRequested&) {
        throw;
      } catch (const std::exception&) {
        // The failed run's iterations are not reported; count the evaluations it used.
        iterations_left -= std::max(1, objective.evaluations() - report.evaluations);
        report.evaluations = objective.evaluations();
        ++report.iterations;
      }
      if (!(objective.best_value() < previous_best * (1 - config.relative_improvement_tolerance)))
        break;
      previous_best = objective.best_value();
    }
  } catch (const internal::StopRequested&) {
    return Error{ErrorCode::kCancelled, "trajectory optimisation stopped by the caller"};
  }
  // Leave *minco at the best point evaluated (the solver's last evaluation may be a trial).
  objective.Apply(objective.best_x());
  report.evaluations = objective.evaluations();
  Eigen::MatrixXd grad_c;
  report.final_cost = cost.Evaluate(*minco, &grad_c, &scratch, &report.final_terms);
  return report;
}

}  // namespace strata
