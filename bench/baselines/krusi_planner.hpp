#pragma once
// Krüsi-style baseline (Krüsi et al., "Driving on point clouds", 2017; paper ref.
// [krusi2017driving]): sampling-based planning straight on the point cloud with on-demand
// terrain assessment (KrusiTerrain). OMPL's RRT-Connect finds the first path in the space of
// reference points (x, y, z), where z selects the level and every state is projected onto the
// cloud's surface by the assessment; then the path is refined under a time limit by OMPL's
// PathSimplifier (shortcutting, which rewires the path between its own states like RRT*'s
// rewiring restricted to the path, and B-spline smoothing), all motions re-checked on the
// cloud. Output is the point path, without time parametrisation.

#include <cstdint>
#include <memory>

#include "baselines/baseline_path.hpp"
#include "baselines/baseline_robot.hpp"
#include "baselines/krusi_terrain.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata::baselines {

/// Tuning of the Krüsi-style baseline (bench/baselines/README.md says how it was chosen).
struct KrusiParams {
  KrusiTerrainParams terrain;  ///< The local assessment.
  double range_m = 1.5;        ///< RRT-Connect's longest extension [m], > 0.
  /// Seconds of the query's time limit kept for the refinement [s], >= 0; RRT-Connect gets
  /// the rest (at least half of the limit).
  double refine_time_s = 0.2;
  double snap_tolerance_m = 1.0;  ///< Farthest valid state start/goal may move to [m].
  int snap_candidates = 64;       ///< Cloud points tried, nearest first, when snapping [-].
};

class KrusiPlanner {
 public:
  ~KrusiPlanner();
  /// Indexes `cloud` (the method's whole terrain assessment: t_a). kInvalidInput for an empty
  /// cloud.
  static Expected<std::unique_ptr<KrusiPlanner>> Build(const PointCloud& cloud,
                                                       const BaselineRobot& robot,
                                                       const KrusiParams& params);

  /// Seeds OMPL's random generators; effective only before the first plan of the process.
  static void SeedRandom(std::uint32_t seed);

  /// RRT-Connect, then refinement, within time_limit_s. kStartOffGround / kGoalOffGround when
  /// no valid state lies within snap_tolerance_m, kDeadlineExceeded when RRT-Connect finds no
  /// path in its time. Not thread-safe (OMPL planners keep state).
  Expected<BaselinePath> Plan(const Eigen::Vector3d& start_m, const Eigen::Vector3d& goal_m,
                              double time_limit_s) const;

  double assessment_s() const;  ///< Building the kd-tree [s]: the method's t_a.
  double point_spacing_m() const;

 private:
  struct Impl;
  explicit KrusiPlanner(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace strata::baselines
