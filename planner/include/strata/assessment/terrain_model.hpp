#pragma once
/// The result of terrain assessment (paper Secs. III–IV): immutable once built and shared
/// read-only by every planning request on the map.

#include <concepts>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <type_traits>

#include <Eigen/Core>

#include "strata/assessment/assessment_control.hpp"
#include "strata/assessment/grid.hpp"
#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_fields.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

/// Wall-clock seconds spent in each assessment stage.
struct AssessmentTimings {
  double ground_filter_s = 0;  ///< Sorting the points into columns, Valid Ground Filter.
  double surfaces_s = 0;       ///< Column surfaces and their plane fits.
  double fields_s = 0;         ///< d and S' on the band, tile by tile.
  double total_s = 0;          ///< All of the above (excludes loading the file).
};

/// Counts and figures reported for an assessed map.
struct AssessmentSummary {
  std::size_t input_points = 0;  ///< Finite points assessed.
  /// Points kept by the Valid Ground Filter (M^s), counted after each column is thinned to
  /// one point per cube of a cell edge / 8 (a denser cloud counts fewer than it holds).
  std::size_t valid_ground_points = 0;
  std::size_t surface_count = 0;        ///< Column surfaces (levels) of any kind.
  std::size_t valid_surface_count = 0;  ///< Column surfaces holding valid ground.
  Eigen::AlignedBox3d cloud_bounds_m;   ///< Bounding box of the input points [m].
  /// Height step of a voxelised cloud (all heights on a lattice, e.g. 0.2 m for the shared
  /// maps), 0 for a sensor's cloud. The ground filter lets a neighbour up to 1.05× this
  /// higher and at least half of it away horizontally pass as a step (FilterValidGround), or
  /// every voxelised slope would be a staircase of walls to it.
  double vertical_quantum_m = 0;
  AssessmentTimings timings;
};

/// Calls visit(name, field) for every field of `summary` (AssessmentSummary, const or not):
/// the one list of its fields, which a saved model follows.
template <typename Summary, typename Visit>
requires std::same_as<std::remove_const_t<Summary>, AssessmentSummary>
void ForEachField(Summary& summary, Visit&& visit) {
  visit("input_points", summary.input_points);
  visit("valid_ground_points", summary.valid_ground_points);
  visit("surface_count", summary.surface_count);
  visit("valid_surface_count", summary.valid_surface_count);
  visit("cloud_bounds_m.min.x", summary.cloud_bounds_m.min().x());
  visit("cloud_bounds_m.min.y", summary.cloud_bounds_m.min().y());
  visit("cloud_bounds_m.min.z", summary.cloud_bounds_m.min().z());
  visit("cloud_bounds_m.max.x", summary.cloud_bounds_m.max().x());
  visit("cloud_bounds_m.max.y", summary.cloud_bounds_m.max().y());
  visit("cloud_bounds_m.max.z", summary.cloud_bounds_m.max().z());
  visit("vertical_quantum_m", summary.vertical_quantum_m);
  visit("timings.ground_filter_s", summary.timings.ground_filter_s);
  visit("timings.surfaces_s", summary.timings.surfaces_s);
  visit("timings.fields_s", summary.timings.fields_s);
  visit("timings.total_s", summary.timings.total_s);
}

/// The height step of a voxelised cloud (see AssessmentSummary::vertical_quantum_m): on a
/// sample of up to 20k points, when the heights (to 0.1 mm) held by at least three sampled
/// points are at most 4000, all differences multiples of the smallest, and that is at least
/// 1 cm, and at most 0.1% of the sample lie at other heights (stray points, ignored); else 0.
double DetectVerticalQuantum(const PointCloud& cloud);

/// The plane-fit settings used on a cloud with this vertical quantum at this grid
/// resolution: `field` unchanged for a sensor's cloud (quantum 0) or a lattice finer than half
/// a cell; otherwise the fit takes the column tops only (FieldConfig::plane_fit_column_tops),
/// its radius grows to at least 5 quanta, its band to 1.5 and the RANSAC inlier band to 0.75
/// quanta, so a voxel staircase fits as the slope it samples and a one-voxel groove as flat.
FieldConfig FieldConfigForQuantum(const FieldConfig& field, double vertical_quantum_m,
                                  double resolution_m);

/// An assessed map: the surfaces of every column and the fields d and S' on the band around
/// valid ground (TerrainFields).
class TerrainModel {
 public:
  /// Assesses `cloud` (finite points, e.g. from LoadPointCloud or SanitizeCloud). Its work and
  /// memory grow with the points and the columns of the grid, not with the grid's volume; the
  /// grid's size is checked against config.grid.max_columns before anything else. Fails with
  /// kInvalidConfig naming the bad field, kInvalidInput for an empty cloud,
  /// kResourceExhausted when the grid would exceed config.grid.max_columns, or kCancelled when
  /// control.should_stop asked to stop.
  ///
  /// The cloud's vertical quantum is detected (DetectVerticalQuantum) unless
  /// `vertical_quantum_m` gives it: a map's quantum is found when the map is made from its
  /// source and kept by its edits, which put their points on its lattice (ApplyEdits).
  static Expected<std::shared_ptr<const TerrainModel>> Assess(
      const PointCloud& cloud, const AssessmentConfig& config,
      const AssessmentControl& control = {},
      std::optional<double> vertical_quantum_m = std::nullopt);

  /// A model from its parts, as a saved model stores them: the surfaces and fields must share
  /// one grid (kInvalidInput otherwise).
  static Expected<std::shared_ptr<const TerrainModel>> FromParts(const AssessmentConfig& config,
                                                                 const AssessmentSummary& summary,
                                                                 SurfaceMap surfaces,
                                                                 TerrainFields fields);

  const AssessmentConfig& config() const { return config_; }
  const GridGeometry& grid() const { return surfaces_.geometry(); }
  const AssessmentSummary& summary() const { return summary_; }
  const SurfaceMap& surfaces() const { return surfaces_; }
  const TerrainFields& fields() const { return fields_; }

  /// Signed distance to the nearest obstacle d(p) [m], trilinear; gradient optional [-].
  double Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const {
    return fields_.Distance(p, gradient);
  }
  /// Diffused safety penalty S'(p) [-], trilinear; gradient optional [1/m].
  double SafetyPenalty(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const {
    return fields_.SafetyPenalty(p, gradient);
  }

  /// Bytes held by the model (surfaces and fields), not counting the object itself.
  std::size_t MemoryBytes() const { return surfaces_.MemoryBytes() + fields_.MemoryBytes(); }
  /// The bytes of the arrays `other` (a model on the same grid, e.g. the base of an edit) does
  /// not share with this one: what making this model allocated beyond it.
  std::size_t MemoryBytesBeyond(const TerrainModel& other) const {
    return surfaces_.MemoryBytesBeyond(other.surfaces_) + fields_.MemoryBytesBeyond(other.fields_);
  }

 private:
  TerrainModel() = default;

  AssessmentConfig config_;
  AssessmentSummary summary_;
  SurfaceMap surfaces_;
  TerrainFields fields_;
};

}  // namespace strata
