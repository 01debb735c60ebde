#pragma once
/// Parameters of terrain assessment, one struct per stage. Every field documents its unit and
/// valid range; Validate() blames the first bad field by its path (Error::field), which starts
/// with `path`, the struct's own path: "ground.radius_m" for an AssessmentConfig's ground filter.

#include <concepts>
#include <cstdint>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>

#include "strata/status.hpp"

namespace strata {

/// Valid Ground Filter (paper Sec. III, eq. 1; docs/design.md §3).
struct GroundFilterConfig {
  /// Neighbourhood radius r [m], > 0. At least the radius of the sphere enclosing the robot.
  double radius_m = 0.3;
  /// Steepest slope θ the robot may stand on [rad], in (0, π/2).
  double max_tilt_rad = 20.0 * std::numbers::pi / 180.0;
  /// Height noise tolerated [m], >= 0: a neighbour above blocks p only when it rises more than
  /// tan(θ)·(horizontal distance) + this. Keeps sensor noise on a flat floor from rejecting it;
  /// 0 gives the paper's rule exactly.
  double height_tolerance_m = 0.02;

  Status Validate(std::string_view path = "ground") const;
};

/// The 3D grid the surfaces and the fields d and S' are laid on. Only the band of cells around
/// valid ground holds field values (strata/assessment/terrain_fields.hpp), so the grid's volume
/// costs nothing; its columns cost a few bytes of index each.
struct GridConfig {
  double resolution_m = 0.2;  ///< Cell edge r_g [m], in [0.02, 5].
  /// Margin added around the cloud's bounds [m], in [0, 100]; room above the top surface for
  /// the robot's body and for the optimiser to push against.
  double padding_m = 1.0;
  /// Height above each valid surface up to which d and S' are kept [m], in (0, 100]. The
  /// planner reads them at a robot's reference point, so it must be at least the highest
  /// RobotProfile::reference_height_m planned on the map (CheckProfileFitsMap refuses
  /// others); the default leaves room for a body up to 0.85 m plus the optimiser's 0.15 m
  /// distance threshold. Each 0.2 m of band costs 4 bytes per column of ground.
  double band_height_m = 1.0;
  /// d is exact up to this distance from the nearest cell of the other class and reads this
  /// value (or its negative inside obstacles) beyond it [m], in (0, 32]. Plan refuses
  /// thresholds that reach it (kInvalidConfig). Each tile is transformed with a halo of this.
  double distance_cap_m = 1.0;
  /// Largest grid accepted [columns, x × y cells], > 0: about 16 bytes of index per column
  /// during assessment. Checked from the cloud's bounds before any heavy work.
  std::int64_t max_columns = 100'000'000;

  Status Validate(std::string_view path = "grid") const;
};

/// Safety penalty field S and its diffusion S' (paper Sec. IV).
struct FieldConfig {
  double weight_tilt = 1.0;         ///< λ_f, weight of φ² [1/rad²], >= 0.
  double weight_pose_change = 1.0;  ///< λ_m, weight of sqrt(‖∇H‖) [-], >= 0.
  /// Diffusion distance t of the cone kernel [m], >= 0 (0 disables diffusion: S' = S).
  double diffusion_distance_m = 0.4;
  /// Horizontal radius of the neighbourhood used for the local plane fit [m], > 0.
  double plane_fit_radius_m = 0.35;
  /// Half-height of that neighbourhood around the ground height [m], > 0. Keeps a slab's
  /// underside (and whatever hangs above) out of its top surface's fit; a slope up to θ
  /// (tan 20° · 0.35 m = 0.13 m) still fits inside.
  double plane_fit_half_height_m = 0.15;
  /// Fit only the highest point of each column in that neighbourhood. For voxelised clouds,
  /// where a column holds one point per voxel and a solid's interior voxels would pull the
  /// plane; FieldConfigForQuantum sets it when the cloud has a vertical quantum.
  bool plane_fit_column_tops = false;
  /// A point within this distance of a candidate plane is a RANSAC inlier [m], > 0.
  double plane_inlier_distance_m = 0.05;
  /// RANSAC iterations per patch that is not already a clean plane [-], >= 1.
  int plane_ransac_iterations = 64;
  /// Cap on ‖∇H‖ [1/m]; also the value used where a neighbour has no surface below, so the
  /// rim of a drop into nothing gets the largest pose-change penalty, > 0. (A neighbour inside
  /// a wall is left out: strata/safety_field.hpp.)
  double max_pose_gradient_per_m = 25.0;

  Status Validate(std::string_view path = "field") const;
  /// Penalty where no surface lies below: λ_f (π/2)² + λ_m sqrt(max ‖∇H‖).
  double VoidPenalty() const;
};

/// Everything terrain assessment needs.
struct AssessmentConfig {
  GroundFilterConfig ground;
  GridConfig grid;
  FieldConfig field;
  /// Worker threads for the parallel stages [-], >= 0; 0 uses every core.
  int num_threads = 0;

  Status Validate(std::string_view path = "") const;
};

/// Calls visit(path, field) for every field of `config` (AssessmentConfig or const
/// AssessmentConfig), path being its name as Validate() reports it (e.g. "grid.resolution_m").
/// The one list of the fields: whatever copies or stores them all (a saved model) follows it,
/// so a new field cannot be forgotten there.
template <typename Config, typename Visit>
requires std::same_as<std::remove_const_t<Config>, AssessmentConfig>
void ForEachField(Config& config, Visit&& visit) {
  visit("ground.radius_m", config.ground.radius_m);
  visit("ground.max_tilt_rad", config.ground.max_tilt_rad);
  visit("ground.height_tolerance_m", config.ground.height_tolerance_m);
  visit("grid.resolution_m", config.grid.resolution_m);
  visit("grid.padding_m", config.grid.padding_m);
  visit("grid.band_height_m", config.grid.band_height_m);
  visit("grid.distance_cap_m", config.grid.distance_cap_m);
  visit("grid.max_columns", config.grid.max_columns);
  visit("field.weight_tilt", config.field.weight_tilt);
  visit("field.weight_pose_change", config.field.weight_pose_change);
  visit("field.diffusion_distance_m", config.field.diffusion_distance_m);
  visit("field.plane_fit_radius_m", config.field.plane_fit_radius_m);
  visit("field.plane_fit_half_height_m", config.field.plane_fit_half_height_m);
  visit("field.plane_fit_column_tops", config.field.plane_fit_column_tops);
  visit("field.plane_inlier_distance_m", config.field.plane_inlier_distance_m);
  visit("field.plane_ransac_iterations", config.field.plane_ransac_iterations);
  visit("field.max_pose_gradient_per_m", config.field.max_pose_gradient_per_m);
  visit("num_threads", config.num_threads);
}

/// The path of the first field (in ForEachField's order) whose value differs between `a` and
/// `b`, leaving out num_threads (how to assess, not what), or nothing when they assess alike.
std::optional<std::string> FirstDifference(const AssessmentConfig& a, const AssessmentConfig& b);

/// A saved model is assessed already and keeps its parameters: kInvalidConfig, naming the
/// saved model `model` and blaming the first field (FirstDifference) where `asked` assesses
/// otherwise than `saved`, the parameters it was assessed with.
Status CheckSavedModelParameters(const AssessmentConfig& asked, const AssessmentConfig& saved,
                                 std::string_view model);

}  // namespace strata
