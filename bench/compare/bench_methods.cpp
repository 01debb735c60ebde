#include "compare/bench_methods.hpp"

#include <chrono>
#include <cstdio>

#include "baselines/krusi_planner.hpp"
#include "baselines/liu_planner.hpp"
#include "compare/bench_metrics.hpp"
#include "verifier_bounds.hpp"

namespace strata::bench {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string Seconds(const char* stage, double s) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s=%.4f", stage, s);
  return buf;
}

QueryOutcome Failure(const Error& error, double plan_s) {
  QueryOutcome out;
  out.reason = ErrorCodeName(error.code);
  out.message = error.message;
  out.plan_s = plan_s;
  return out;
}

class StrataMethod : public BenchMethod {
 public:
  StrataMethod(std::shared_ptr<const PlanningMap> map, const RobotProfile& profile,
               double assessment_s, std::string detail)
      : map_(std::move(map)),
        profile_(profile),
        assessment_s_(assessment_s),
        detail_(std::move(detail)) {}
  const char* name() const override { return "strata"; }
  double assessment_s() const override { return assessment_s_; }
  std::string assessment_detail() const override { return detail_; }

  QueryOutcome Run(const QueryPair& pair, double time_limit_s) override {
    PlanRequest request;
    request.start.position_m = pair.start_m;
    request.goal.position_m = pair.goal_m;
    request.profile = profile_;
    request.options.time_budget_s = time_limit_s;
    const auto begin = Clock::now();
    const Expected<PlanResult> plan = Plan(*map_, request);
    const double plan_s = SecondsSince(begin);
    if (!plan) return Failure(plan.error(), plan_s);

    QueryOutcome out;
    out.success = true;
    out.plan_s = plan_s;
    out.length_m = plan->stats.length_m;
    out.kappa_m = TrajectoryMeanCurvature(plan->trajectory, CurvatureSpace::k3d);
    out.kappa_xy_m = TrajectoryMeanCurvature(plan->trajectory, CurvatureSpace::kPlanar);
    out.duration_s = plan->stats.duration_s;
    out.duration_ratio =
        out.length_m > 0 ? out.duration_s * profile_.max_speed_horizontal_mps / out.length_m : 0;
    out.time_stretch = plan->stats.time_stretch;
    out.fallback = plan->stats.fallback;
    out.message = plan->stats.fallback_reason;
    out.iterations = plan->stats.optimizer_iterations;
    out.limiting_bound = plan->stats.limiting_bound;
    out.start_snap_m = plan->start.distance_m;
    out.goal_snap_m = plan->goal.distance_m;
    out.points_m = SampleTrajectory(plan->trajectory);
    // Independent of Plan's own final check: a returned plan that fails is a failure here.
    const auto graph = map_->Graph(profile_.Traversability());
    VerificationReport report;
    const Status verified =
        graph ? VerifyTrajectory(**graph, profile_, plan->trajectory, VerifierConfig{}, &report)
              : Status(graph.error());
    out.verify_violations = verified ? 0 : 1;
    out.check = bench::CheckTrajectory(map_->model(), profile_, plan->trajectory,
                                       bench::CheckConfigFor(VerifierConfig{}));
    if (!verified) {
      out.success = false;
      out.reason = "VERIFY_FAILED";
      out.message = verified.error().message;
    }
    return out;
  }

 private:
  std::shared_ptr<const PlanningMap> map_;
  RobotProfile profile_;
  double assessment_s_;
  std::string detail_;
};

// Shared by both baselines: point path → outcome.
QueryOutcome PathOutcome(const baselines::BaselinePath& path, double plan_s) {
  QueryOutcome out;
  out.success = true;
  out.plan_s = plan_s;
  out.length_m = PolylineLength(path.points_m);
  out.kappa_m = PathMeanCurvature(path.points_m, CurvatureSpace::k3d);
  out.kappa_xy_m = PathMeanCurvature(path.points_m, CurvatureSpace::kPlanar);
  out.start_snap_m = path.start_snap_m;
  out.goal_snap_m = path.goal_snap_m;
  out.points_m = path.points_m;
  return out;
}

// Runs a baseline, which returns a point path, on one query.
template <typename PathPlanner>
QueryOutcome RunPathPlanner(const PathPlanner& planner, const QueryPair& pair,
                            double time_limit_s) {
  const auto begin = Clock::now();
  const auto path = planner.Plan(pair.start_m, pair.goal_m, time_limit_s);
  const double plan_s = SecondsSince(begin);
  return path ? PathOutcome(*path, plan_s) : Failure(path.error(), plan_s);
}

class LiuMethod : public BenchMethod {
 public:
  explicit LiuMethod(std::unique_ptr<baselines::LiuPlanner> planner)
      : planner_(std::move(planner)) {}
  const char* name() const override { return "liu"; }
  double assessment_s() const override { return planner_->timings().total_s; }
  std::string assessment_detail() const override {
    const baselines::LiuTimings& t = planner_->timings();
    return Seconds("normals_s", t.normals_s) + " " +
           Seconds("traversability_s", t.traversability_s) + " " + Seconds("graph_s", t.graph_s) +
           " traversable_points=" + std::to_string(planner_->traversable_count()) +
           " edges=" + std::to_string(planner_->edge_count());
  }
  QueryOutcome Run(const QueryPair& pair, double time_limit_s) override {
    return RunPathPlanner(*planner_, pair, time_limit_s);
  }

 private:
  std::unique_ptr<baselines::LiuPlanner> planner_;
};

class KrusiMethod : public BenchMethod {
 public:
  explicit KrusiMethod(std::unique_ptr<baselines::KrusiPlanner> planner)
      : planner_(std::move(planner)) {}
  const char* name() const override { return "krusi"; }
  double assessment_s() const override { return planner_->assessment_s(); }
  std::string assessment_detail() const override {
    return Seconds("kdtree_s", planner_->assessment_s());
  }
  QueryOutcome Run(const QueryPair& pair, double time_limit_s) override {
    return RunPathPlanner(*planner_, pair, time_limit_s);
  }

 private:
  std::unique_ptr<baselines::KrusiPlanner> planner_;
};

class FailedMethod : public BenchMethod {
 public:
  FailedMethod(const char* name, Error error) : name_(name), error_(std::move(error)) {}
  const char* name() const override { return name_; }
  double assessment_s() const override { return 0; }
  std::string assessment_detail() const override {
    return std::string("failed: ") + ErrorCodeName(error_.code) + ": " + error_.message;
  }
  QueryOutcome Run(const QueryPair&, double) override { return Failure(error_, 0); }

 private:
  const char* name_;
  Error error_;
};

}  // namespace

std::unique_ptr<BenchMethod> MakeFailedMethod(const char* name, const Error& error) {
  return std::make_unique<FailedMethod>(name, error);
}

std::unique_ptr<BenchMethod> MakeStrataMethod(std::shared_ptr<const PlanningMap> map,
                                              const RobotProfile& profile, double assessment_s,
                                              std::string assessment_detail) {
  return std::make_unique<StrataMethod>(std::move(map), profile, assessment_s,
                                        std::move(assessment_detail));
}

Expected<std::unique_ptr<BenchMethod>> MakeLiuMethod(const PointCloud& cloud,
                                                     const RobotProfile& profile, int threads) {
  baselines::LiuParams params;
  params.num_threads = threads;
  auto planner =
      baselines::LiuPlanner::Build(cloud, baselines::BaselineRobot::FromProfile(profile), params);
  if (!planner) return planner.error();
  return std::unique_ptr<BenchMethod>(new LiuMethod(std::move(planner).value()));
}

Expected<std::unique_ptr<BenchMethod>> MakeKrusiMethod(const PointCloud& cloud,
                                                       const RobotProfile& profile,
                                                       double refine_time_s) {
  baselines::KrusiParams params;
  if (refine_time_s >= 0) params.refine_time_s = refine_time_s;
  auto planner =
      baselines::KrusiPlanner::Build(cloud, baselines::BaselineRobot::FromProfile(profile), params);
  if (!planner) return planner.error();
  return std::unique_ptr<BenchMethod>(new KrusiMethod(std::move(planner).value()));
}

}  // namespace strata::bench
