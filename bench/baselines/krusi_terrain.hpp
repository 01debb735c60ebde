#pragma once
// On-demand terrain assessment of the Krüsi-style baseline (Krüsi et al., "Driving on point
// clouds", 2017; paper ref. [krusi2017driving]): nothing is precomputed but a kd-tree; every
// state the planner samples or passes through is assessed from the cloud points around it
// when it is asked about, and nothing is cached.

#include <optional>

#include <Eigen/Core>

#include "baselines/baseline_robot.hpp"
#include "baselines/cloud_search.hpp"

namespace strata::baselines {

/// Tuning of the local assessment (bench/baselines/README.md says how it was chosen).
struct KrusiTerrainParams {
  /// The ground under a state is looked for within this height of its reference point −
  /// reference height [m], > 0: the "level" the state's z selects.
  double ground_window_m = 0.25;
  /// Roughness bound: RMS distance of the patch from its plane [m], > 0 (the same measure and
  /// bound as the Liu-style baseline: half the robot's step).
  double max_roughness_m = 0.075;
  /// Support disc radius = max(footprint radius, this × point spacing) [-] (see LiuParams).
  double support_spacings = 2.5;
  int min_patch_points = 6;         ///< Fewest ground points for a plane fit [-], >= 3.
  double check_resolution_m = 0.1;  ///< Spacing of the states checked along a motion [m], > 0.
};

class KrusiTerrain {
 public:
  /// `search` indexes the whole cloud and must outlive this object; spacing_m is its point
  /// spacing (CloudSearch::MedianSpacing).
  KrusiTerrain(const CloudSearch& search, const BaselineRobot& robot,
               const KrusiTerrainParams& params, double spacing_m);

  /// Assesses the place of reference point `reference_m`: fits a plane (PCA) to the cloud
  /// points in the support disc within ground_window_m of reference − reference height, and
  /// accepts it when the fit has enough points, tilt <= θ, roughness <= the bound, its height
  /// under (x, y) is within the window, and CheckFootprint passes. Returns the ground height
  /// under (x, y) [m], or nothing. Thread-safe.
  std::optional<float> GroundUnder(const Eigen::Vector3d& reference_m) const;

  /// Whether the straight motion a → b (reference points) stays on valid ground: every state
  /// check_resolution_m apart passes GroundUnder, and the ground between consecutive states
  /// changes by at most step + horizontal distance·tanθ. *last_valid_fraction (optional)
  /// gets the fraction of the motion up to the last valid state.
  bool MotionValid(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   double* last_valid_fraction = nullptr) const;

  const BaselineRobot& robot() const { return robot_; }
  const CloudSearch& search() const { return search_; }

 private:
  const CloudSearch& search_;
  BaselineRobot robot_;
  KrusiTerrainParams params_;
  double spacing_m_;
  double support_radius_m_;
  double query_radius_m_;
  float center_lift_m_;
};

}  // namespace strata::baselines
