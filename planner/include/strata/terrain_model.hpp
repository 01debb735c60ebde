#pragma once
/// The result of terrain assessment (paper Secs. III–IV): immutable once built and shared
/// read-only by every planning request on the map.

#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "strata/grid.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"
#include "strata/surface_map.hpp"
#include "strata/terrain_config.hpp"

namespace strata {

/// Wall-clock seconds spent in each assessment stage.
struct AssessmentTimings {
  double ground_filter_s = 0;  ///< Valid Ground Filter.
  double esdf_s = 0;           ///< Grid geometry, occupancy and signed distance field.
  double field_s = 0;          ///< Surfaces, plane fits, S and its diffusion S'.
  double total_s = 0;          ///< All of the above (excludes loading the file).
};

/// Counts and figures reported for an assessed map.
struct AssessmentSummary {
  std::size_t input_points = 0;         ///< Finite points assessed.
  std::size_t valid_ground_points = 0;  ///< Points kept by the Valid Ground Filter (M^s).
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

/// An assessed map: ESDF d, safety penalty field S', and the surfaces of every column.
class TerrainModel {
 public:
  /// Assesses `cloud` (finite points, e.g. from LoadPointCloud or SanitizeCloud). Fails with
  /// kInvalidConfig naming the bad field, kInvalidInput for an empty cloud, or
  /// kResourceExhausted when the grid would exceed config.grid.max_cells.
  static Expected<std::shared_ptr<const TerrainModel>> Assess(const PointCloud& cloud,
                                                              const AssessmentConfig& config);

  const AssessmentConfig& config() const { return config_; }
  const GridGeometry& grid() const { return surfaces_.geometry(); }
  const AssessmentSummary& summary() const { return summary_; }
  const SurfaceMap& surfaces() const { return surfaces_; }
  const ScalarGrid& distance_field() const { return esdf_; }
  const ScalarGrid& safety_field() const { return safety_; }

  /// Signed distance to the nearest obstacle d(p) [m], trilinear; gradient optional [-].
  double Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const {
    return esdf_.Sample(p, gradient);
  }
  /// Diffused safety penalty S'(p) [-], trilinear; gradient optional [1/m].
  double SafetyPenalty(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const {
    return safety_.Sample(p, gradient);
  }

  /// Bytes held by the model (fields and surfaces), not counting the object itself.
  std::size_t MemoryBytes() const {
    return esdf_.MemoryBytes() + safety_.MemoryBytes() + surfaces_.MemoryBytes();
  }

 private:
  TerrainModel() = default;

  AssessmentConfig config_;
  AssessmentSummary summary_;
  SurfaceMap surfaces_;
  ScalarGrid esdf_;
  ScalarGrid safety_;
};

}  // namespace strata
