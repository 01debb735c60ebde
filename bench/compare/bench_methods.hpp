#pragma once
// The three planners of the comparison behind one interface, so the harness treats them
// alike: t_a once per map, then one Run per query, measured the same way (bench_metrics).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "compare/bench_pairs.hpp"
#include "independent_check.hpp"
#include "strata/planner.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/point_cloud.hpp"

namespace strata::bench {

/// What one method did on one query.
struct QueryOutcome {
  bool success = false;
  std::string reason = "OK";  ///< "OK" or an ErrorCodeName (VERIFY_FAILED: see below).
  /// The failure's message; on a success, Strata's fallback_reason (else empty).
  std::string message;
  double plan_s = 0;    ///< Wall-clock seconds of the query (snapping included).
  double length_m = 0;  ///< Path or trajectory length [m].
  /// κ_m, the mean curvature of paper Table 2 [1/m], over uniform arc-length samples of the
  /// curve in 3D, the same for every method (bench_metrics.hpp).
  double kappa_m = 0;
  /// κ_m of the curve's x–y projection, the same for every method [1/m]: how the path turns,
  /// without the height noise of paths that join raw cloud points.
  double kappa_xy_m = 0;
  /// Strata only (0 for the baselines, whose paths are not timed): the trajectory's duration
  /// [s], its ratio to driving its length at the horizontal speed bound, the time stretch
  /// applied, whether it is the slow fallback, the optimiser's iterations, and the bound the
  /// trajectory came closest to (PlanStats::limiting_bound).
  double duration_s = 0;
  double duration_ratio = 0;
  double time_stretch = 0;
  bool fallback = false;
  int iterations = 0;
  std::string limiting_bound;
  /// Strata only: 1 when the returned trajectory fails an independent VerifyTrajectory (then
  /// success is false and reason VERIFY_FAILED), else 0; -1 for the baselines.
  int verify_violations = -1;
  /// Strata's returned plans: what the harness's own check found (independent_check.hpp).
  std::optional<bench::IndependentCheckCounts> check;
  double start_snap_m = 0;                ///< How far the method moved the start [m].
  double goal_snap_m = 0;                 ///< How far the method moved the goal [m].
  std::vector<Eigen::Vector3d> points_m;  ///< The path (Strata: sampled every 0.1 m) [m].
};

class BenchMethod {
 public:
  virtual ~BenchMethod() = default;
  virtual const char* name() const = 0;
  /// Terrain assessment time t_a of the map [s].
  virtual double assessment_s() const = 0;
  /// Its stages, "stage=seconds" separated by spaces.
  virtual std::string assessment_detail() const = 0;
  virtual QueryOutcome Run(const QueryPair& pair, double time_limit_s) = 0;
};

/// Strata on an assessed map; assessment_s and detail as measured by the caller (assessment
/// plus the profile's graph build).
std::unique_ptr<BenchMethod> MakeStrataMethod(std::shared_ptr<const PlanningMap> map,
                                              const RobotProfile& profile, double assessment_s,
                                              std::string assessment_detail);
/// The Liu-style baseline, assessed now (t_a measured inside) with `threads` OpenMP threads.
Expected<std::unique_ptr<BenchMethod>> MakeLiuMethod(const PointCloud& cloud,
                                                     const RobotProfile& profile, int threads);
/// The Krüsi-style baseline (t_a = its kd-tree build); refine_time_s < 0 keeps
/// KrusiParams::refine_time_s.
Expected<std::unique_ptr<BenchMethod>> MakeKrusiMethod(const PointCloud& cloud,
                                                       const RobotProfile& profile,
                                                       double refine_time_s = -1);

/// A method whose assessment failed: every query fails with the assessment's error, so the
/// run still reports the method (t_a = 0) instead of stopping.
std::unique_ptr<BenchMethod> MakeFailedMethod(const char* name, const Error& error);

}  // namespace strata::bench
