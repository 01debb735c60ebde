#include "strata/planner.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>

#include "format_internal.hpp"
#include "strata/terrain_query.hpp"

namespace strata {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// One should_stop for every stage: the caller's cancellation and the plan's own deadline,
// remembering which fired so the failure names the right reason.
class StopCondition {
 public:
  StopCondition(const std::function<bool()>& caller, Clock::time_point deadline)
      : caller_(caller), deadline_(deadline) {}

  bool operator()() {
    if (caller_ && caller_()) cancelled_ = true;
    if (!cancelled_ && Clock::now() >= deadline_) expired_ = true;
    return cancelled_ || expired_;
  }
  std::function<bool()> AsFunction() {
    return [this] { return (*this)(); };
  }
  // The error for a stage that stopped on our request.
  Error Reason(double budget_s, const char* stage) const {
    if (cancelled_)
      return Error{ErrorCode::kCancelled, std::string("plan cancelled during ") + stage};
    char buf[200];
    std::snprintf(buf, sizeof(buf),
                  "the plan's time budget of %.3f s ran out during %s; allow more time "
                  "(options.time_budget_s or the call's deadline)",
                  budget_s, stage);
    return Error{ErrorCode::kDeadlineExceeded, buf};
  }
  bool stopped() const { return cancelled_ || expired_; }

 private:
  const std::function<bool()>& caller_;
  Clock::time_point deadline_;
  bool cancelled_ = false;
  bool expired_ = false;
};

// Where the trajectory starts or ends: the requested x, y on the ground when they lie in the
// snapped node's column (the robot is where it says), else the node's reference point.
Eigen::Vector3d BoundaryPosition(const SurfaceGraph& graph, const SnapResult& snap,
                                 const Eigen::Vector3d& requested) {
  Eigen::Vector3d node = snap.position_m;
  const Eigen::Vector3d candidate(requested.x(), requested.y(), node.z());
  if (graph.grid().CellOf(candidate).head<2>() != graph.cell(snap.node).head<2>()) return node;
  GroundSample ground;
  const double h_ref = graph.params().reference_height_m;
  if (!SampleGround(graph.model(), candidate, h_ref, 0, &ground)) return node;
  return {requested.x(), requested.y(), ground.height_m + h_ref};
}

void FillStats(const Trajectory& trajectory, const VerificationReport& v, PlanStats* stats) {
  stats->length_m = PathLength(trajectory);
  stats->duration_s = trajectory.TotalDuration();
  stats->mean_curvature_per_m = MeanCurvature(trajectory);
  stats->max_speed_horizontal_mps = v.max_speed_horizontal_mps;
  stats->max_speed_vertical_mps = v.max_speed_vertical_mps;
  stats->max_accel_horizontal_mps2 = v.max_accel_horizontal_mps2;
  stats->max_accel_vertical_mps2 = v.max_accel_vertical_mps2;
  stats->min_obstacle_distance_m = v.min_obstacle_distance_m;
  stats->max_ground_offset_m = v.max_ground_offset_m;
  stats->max_tilt_rad = v.max_tilt_rad;
  stats->min_body_height_m = v.min_body_height_m;
  stats->min_headroom_m = v.min_headroom_m;
  stats->pieces = static_cast<int>(trajectory.pieces.size());
  stats->verified_samples = v.samples;
}

}  // namespace

struct PlanningMap::GraphEntry {
  std::once_flag once;
  std::atomic<bool> built{false};  // Set (release) once graph or error is final.
  std::shared_ptr<const SurfaceGraph> graph;
  Error error{ErrorCode::kInvalidConfig, {}};
};

PlanningMap::PlanningMap(std::shared_ptr<const TerrainModel> model) : model_(std::move(model)) {}

Expected<std::shared_ptr<const SurfaceGraph>> PlanningMap::Graph(
    const TraversabilityParams& params) const {
  if (Status s = params.Validate(); !s) return std::move(s).error();
  std::shared_ptr<GraphEntry> entry;
  {
    std::lock_guard lock(mutex_);
    std::shared_ptr<GraphEntry>& slot = graphs_[params];
    if (slot == nullptr) slot = std::make_shared<GraphEntry>();
    entry = slot;
  }
  std::call_once(entry->once, [&] {
    Expected<SurfaceGraph> graph = SurfaceGraph::Build(*model_, params);
    if (graph) {
      entry->graph = std::make_shared<const SurfaceGraph>(std::move(graph).value());
    } else {
      entry->error = graph.error();
    }
    entry->built.store(true, std::memory_order_release);
  });
  if (entry->graph == nullptr) return entry->error;
  return entry->graph;
}

std::size_t PlanningMap::MemoryBytes() const {
  std::size_t bytes = model_->MemoryBytes();
  std::lock_guard lock(mutex_);
  for (const auto& [key, entry] : graphs_) {
    if (entry->built.load(std::memory_order_acquire) && entry->graph != nullptr) {
      bytes += entry->graph->MemoryBytes();
    }
  }
  return bytes;
}

Status PlanOptions::Validate(std::string_view path) const {
  using internal::FieldPath;
  if (!(std::isfinite(time_budget_s) && time_budget_s > 0)) {
    return internal::OutOfRange(FieldPath(path, "time_budget_s"), time_budget_s, "> 0 and finite");
  }
  if (!(std::isfinite(snap_tolerance_m) && snap_tolerance_m >= 0)) {
    return internal::OutOfRange(FieldPath(path, "snap_tolerance_m"), snap_tolerance_m,
                                ">= 0 and finite");
  }
  if (max_attempts < 1 || max_attempts > 10) {
    return internal::OutOfRange(FieldPath(path, "max_attempts"), max_attempts, "in [1, 10]");
  }
  if (Status s = search.Validate(FieldPath(path, "search")); !s) return s;
  if (Status s = optimizer.Validate(FieldPath(path, "optimizer")); !s) return s;
  return verifier.Validate(FieldPath(path, "verifier"));
}

Status PlanRequest::Validate() const {
  if (Status s = start.Validate("start"); !s) return s;
  if (Status s = goal.Validate("goal"); !s) return s;
  if (Status s = profile.Validate("profile"); !s) return s;
  return options.Validate("options");
}

Expected<PlanResult> Plan(const PlanningMap& map, const PlanRequest& request,
                          const std::function<bool()>& should_stop) {
  const Clock::time_point start_time = Clock::now();
  const PlanOptions& options = request.options;
  const RobotProfile& profile = request.profile;
  if (Status s = request.Validate(); !s) return std::move(s).error();
  if (Status s = CheckProfileFitsMap(profile, map.model().config()); !s) return s.error();
  const auto deadline = start_time + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options.time_budget_s));
  StopCondition stop(should_stop, deadline);

  PlanResult result;
  PlanStats& stats = result.stats;

  // Snap.
  Clock::time_point stage = Clock::now();
  Expected<std::shared_ptr<const SurfaceGraph>> graph_or = map.Graph(profile.Traversability());
  if (!graph_or) return graph_or.error();
  const SurfaceGraph& graph = **graph_or;
  // Off the ground, the position is what the caller must change.
  const auto blame = [](Error error, const char* field) {
    error.field = field;
    return error;
  };
  Expected<SnapResult> start = SnapToSurface(graph, request.start.position_m,
                                             options.snap_tolerance_m, ErrorCode::kStartOffGround);
  if (!start) return blame(std::move(start).error(), "start.position_m");
  Expected<SnapResult> goal = SnapToSurface(graph, request.goal.position_m,
                                            options.snap_tolerance_m, ErrorCode::kGoalOffGround);
  if (!goal) return blame(std::move(goal).error(), "goal.position_m");
  result.start = *start;
  result.goal = *goal;
  stats.timings.snap_s = SecondsSince(stage);

  // Search.
  stage = Clock::now();
  // The search runs on the plan's own budget (through stop), the only one a caller sets.
  SearchStats search_stats;
  Expected<PathResult> path =
      SearchPath(graph, start->node, goal->node, options.search, stop.AsFunction(), &search_stats);
  stats.timings.search_s = SecondsSince(stage);
  stats.search_expansions = search_stats.expansions;
  if (!path) {
    if (stop.stopped()) return stop.Reason(options.time_budget_s, "the path search");
    return std::move(path).error();
  }
  result.path = std::move(path).value();

  // Optimise and verify; a failed verification retries with stiffer penalties.
  std::vector<Eigen::Vector3d> waypoints = result.path.points_m;
  RobotState head = request.start, tail = request.goal;
  head.position_m = BoundaryPosition(graph, result.start, request.start.position_m);
  tail.position_m = BoundaryPosition(graph, result.goal, request.goal.position_m);
  result.start.position_m = head.position_m;
  result.goal.position_m = tail.position_m;
  waypoints.front() = head.position_m;
  waypoints.back() = tail.position_m;
  if (waypoints.size() < 2) waypoints.push_back(tail.position_m);

  OptimizerConfig config = options.optimizer;
  Error last_failure{ErrorCode::kOptimizationFailed, "no optimisation attempt ran"};
  for (int attempt = 0; attempt < options.max_attempts; ++attempt) {
    stage = Clock::now();
    const TrajectoryCost cost(graph, config.weights, CostParams{profile, config.cost});
    const OptimizationProblem problem = MakeInitialProblem(cost, waypoints, head, tail, config);
    Minco3 minco;
    Expected<OptimizationReport> report =
        OptimizeTrajectory(cost, problem, config, stop.AsFunction(), &minco);
    stats.timings.optimize_s += SecondsSince(stage);
    ++stats.optimizer_attempts;
    if (!report) {
      if (stop.stopped()) return stop.Reason(options.time_budget_s, "trajectory optimisation");
      return report.error();
    }
    stats.optimizer_iterations += report->iterations;

    stage = Clock::now();
    Trajectory trajectory = Trajectory::FromMinco(minco);
    VerificationReport verification;
    const Status verified =
        VerifyTrajectory(graph, profile, trajectory, options.verifier, &verification);
    stats.timings.verify_s += SecondsSince(stage);
    if (verified) {
      FillStats(trajectory, verification, &stats);
      result.trajectory = std::move(trajectory);
      stats.timings.total_s = SecondsSince(start_time);
      return result;
    }
    last_failure = verified.error();
    if (stop()) return stop.Reason(options.time_budget_s, "trajectory verification");
    // Stiffer penalties for the next attempt (PlanOptions::max_attempts documents them).
    config.weights.safety *= 4;
    config.weights.edge *= 4;
    config.weights.ground *= 4;
    config.weights.feasibility *= 4;
    config.piece_length_m *= 0.7;
    config.cost.limit_margin *= 0.95;
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), " (after %d attempts)", options.max_attempts);
  last_failure.message += buf;
  return last_failure;
}

}  // namespace strata
