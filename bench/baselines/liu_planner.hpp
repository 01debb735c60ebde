#pragma once
// Liu-style baseline (Liu & Wang, "Robotic path planning on point clouds", 2015; paper ref.
// [liu2015robotic]): per-point local structure of the cloud, a k-nearest-neighbour graph over
// the traversable points weighted by a terrain metric, and Dijkstra. The local structure is
// estimated by PCA of each point's k-neighbourhood (pcl::NormalEstimationOMP), not by tensor
// voting: the normal is the smallest eigenvector, and the spread along it (RMS distance from
// the plane, i.e. the lack of surface saliency) is the roughness. Output is the point path,
// without time parametrisation.

#include <memory>

#include "baselines/baseline_path.hpp"
#include "baselines/baseline_robot.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata::baselines {

/// Tuning of the Liu-style baseline (bench/baselines/README.md says how it was chosen).
struct LiuParams {
  int normal_neighbours = 10;  ///< k of the PCA neighbourhood [-], >= 3.
  /// Roughness bound: RMS distance of the neighbourhood from its PCA plane [m], > 0. The
  /// default is half the differential robot's 0.15 m step: a curb the robot climbs must not
  /// make the ground around it untraversable.
  double max_roughness_m = 0.075;
  int graph_neighbours = 10;  ///< k of the k-NN graph [-], >= 1.
  /// Longest graph edge as a multiple of the cloud's point spacing (median nearest-neighbour
  /// distance) [-], > 1.
  double max_edge_spacings = 3.0;
  /// The footprint's support disc is max(footprint radius, this × point spacing) [-], so a
  /// sparse (voxelised) cloud still shows ground in every quadrant.
  double support_spacings = 2.5;
  double weight_slope = 1.0;      ///< Edge cost factor per unit tilt/θ [-], >= 0.
  double weight_roughness = 1.0;  ///< Edge cost factor per unit roughness/bound [-], >= 0.
  double snap_tolerance_m = 1.0;  ///< Farthest traversable point start/goal may snap to [m].
  int num_threads = 0;            ///< OpenMP threads for the assessment, 0 = all cores.
};

/// Wall-clock seconds of the assessment (the method's t_a is total_s).
struct LiuTimings {
  double normals_s = 0;         ///< kd-tree, PCA normals and roughness.
  double traversability_s = 0;  ///< Tilt, roughness and footprint/body test per point.
  double graph_s = 0;           ///< k-NN graph over traversable points and its components.
  double total_s = 0;
};

class LiuPlanner {
 public:
  ~LiuPlanner();
  /// Assesses `cloud` and builds the graph. kInvalidInput for an empty cloud, kInvalidConfig
  /// for a parameter out of range.
  static Expected<std::unique_ptr<LiuPlanner>> Build(const PointCloud& cloud,
                                                     const BaselineRobot& robot,
                                                     const LiuParams& params);

  /// Dijkstra from the traversable point nearest to start − reference height to the one
  /// nearest to goal − reference height. kStartOffGround / kGoalOffGround when none lies
  /// within snap_tolerance_m, kGoalUnreachable for different components,
  /// kDeadlineExceeded after time_limit_s. Thread-safe.
  Expected<BaselinePath> Plan(const Eigen::Vector3d& start_m, const Eigen::Vector3d& goal_m,
                              double time_limit_s) const;

  const LiuTimings& timings() const;
  std::size_t traversable_count() const;
  std::size_t edge_count() const;
  double point_spacing_m() const;

 private:
  struct Impl;
  explicit LiuPlanner(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace strata::baselines
