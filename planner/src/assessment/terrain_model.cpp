#include "strata/assessment/terrain_model.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "assessment/column_cloud.hpp"
#include "assessment/ground_filter_internal.hpp"
#include "assessment/terrain_fields_build.hpp"
#include "assessment/terrain_model_internal.hpp"

namespace strata {

double DetectVerticalQuantum(const PointCloud& cloud) {
  // On an evenly spaced sample, the distinct heights (to 0.1 mm) of a voxelised map are few
  // and all multiples of one step; a sensor's are many and arbitrary. A voxel map may carry a
  // few stray points off its lattice (scene20.2 has two at z = 0 under a 0.05 + 0.15 k
  // lattice), so heights seen fewer than three times in the sample neither set the step nor
  // break it, as long as such points are rare.
  constexpr std::size_t kSample = 20000;
  constexpr std::size_t kMaxLevels = 4000;
  constexpr double kResolution = 1e-4;
  constexpr std::size_t kMinPointsPerHeight = 3;
  constexpr double kMaxStrayFraction = 1e-3;
  std::vector<std::int64_t> sampled;
  const std::size_t stride = std::max<std::size_t>(1, cloud.size() / kSample);
  for (std::size_t i = 0; i < cloud.size(); i += stride) {
    sampled.push_back(std::llround(cloud[i].z() / kResolution));
  }
  std::sort(sampled.begin(), sampled.end());
  std::vector<std::int64_t> heights;  // Each held by at least kMinPointsPerHeight points.
  std::size_t stray_points = 0;
  for (std::size_t i = 0, j = 0; i < sampled.size(); i = j) {
    while (j < sampled.size() && sampled[j] == sampled[i]) ++j;
    if (j - i >= kMinPointsPerHeight) {
      heights.push_back(sampled[i]);
    } else {
      stray_points += j - i;
    }
  }
  if (heights.size() < 3 || heights.size() > kMaxLevels ||
      static_cast<double>(stray_points) > kMaxStrayFraction * static_cast<double>(sampled.size())) {
    return 0;
  }
  std::int64_t step = std::numeric_limits<std::int64_t>::max();
  for (std::size_t i = 1; i < heights.size(); ++i)
    step = std::min(step, heights[i] - heights[i - 1]);
  if (step * kResolution < 0.01) return 0;  // Finer than a centimetre: not a voxel grid.
  for (std::size_t i = 1; i < heights.size(); ++i) {
    const std::int64_t off = (heights[i] - heights[0]) % step;
    if (std::min(off, step - off) > 2) return 0;  // Not a multiple of the step (±0.2 mm).
  }
  return step * kResolution;
}

namespace internal {

double StepTolerance(double vertical_quantum_m) {
  // A riser of exactly one voxel must pass the ground filter's comparison despite float noise.
  constexpr double kQuantumToleranceFactor = 1.05;
  return kQuantumToleranceFactor * vertical_quantum_m;
}

Expected<GridGeometry> AssessmentGrid(const AssessmentSummary& summary, const GridConfig& grid) {
  // When the resolution is one or two quanta of a voxelised map, a grid laid from the lowest
  // point has a cell boundary through every lattice plane, and rounding empties some columns
  // and doubles others. Half a quantum lower, the points sit inside cells, clear of the
  // boundaries.
  Eigen::AlignedBox3d box = summary.cloud_bounds_m;
  const double q = summary.vertical_quantum_m;
  if (q > 0) {
    const double ratio = grid.resolution_m / q;
    if (ratio <= 2 && std::abs(ratio - std::round(ratio)) < 1e-3) box.min().array() -= 0.5 * q;
  }
  return MakeGridGeometry(box, grid.resolution_m, grid.padding_m, grid.max_columns);
}

}  // namespace internal

FieldConfig FieldConfigForQuantum(const FieldConfig& field, double vertical_quantum_m,
                                  double resolution_m) {
  // On a voxelised map a slope is a staircase whose points lie up to q/2 off its mean plane,
  // and a one-voxel groove or riser leaves a patch whose band ±h holds a single row of
  // points (collinear: no plane, read as a 90° edge). A band of 1.5 q and inliers within
  // 0.75 q see the treads on both sides and fit the slope they make. The radius must span
  // treads too: a least-squares plane over a disc of radius R split by one riser q tilts by
  // atan(8q / (3πR)), 26° for q = 0.2 m and R = 0.35 m but 10° at R = 5q.
  // A quantum well below the cell size is a fine lattice, fitted like a sensor's cloud.
  FieldConfig out = field;
  if (vertical_quantum_m >= 0.5 * resolution_m) {
    out.plane_fit_radius_m = std::max(field.plane_fit_radius_m, 5 * vertical_quantum_m);
    out.plane_fit_column_tops = true;
    out.plane_fit_half_height_m = std::max(field.plane_fit_half_height_m, 1.5 * vertical_quantum_m);
    out.plane_inlier_distance_m =
        std::max(field.plane_inlier_distance_m, 0.75 * vertical_quantum_m);
  }
  return out;
}

const char* AssessmentStageName(AssessmentStage stage) {
  switch (stage) {
    case AssessmentStage::kSorting: return "sorting";
    case AssessmentStage::kGroundFilter: return "ground_filter";
    case AssessmentStage::kSurfaces: return "surfaces";
    case AssessmentStage::kFields: return "fields";
  }
  return "unknown";
}

Expected<std::shared_ptr<const TerrainModel>> TerrainModel::Assess(
    const PointCloud& cloud, const AssessmentConfig& config, const AssessmentControl& control,
    std::optional<double> vertical_quantum_m) {
  if (Status s = config.Validate(); !s) return s.error();
  if (cloud.empty()) {
    return Error{ErrorCode::kInvalidInput, "the point cloud is empty: nothing to assess"};
  }
  internal::Stopwatch total;
  internal::Stopwatch stage;
  internal::ProgressReporter progress(&control);
  const auto cancelled = [](const char* during) {
    return Error{ErrorCode::kCancelled, std::string("terrain assessment cancelled ") + during};
  };
  std::shared_ptr<TerrainModel> model(new TerrainModel());
  model->config_ = config;
  AssessmentSummary& summary = model->summary_;
  summary.input_points = cloud.size();
  if (cloud.size() >= std::numeric_limits<std::uint32_t>::max()) {
    return Error{ErrorCode::kResourceExhausted, "the cloud holds 2^32 points or more"};
  }
  for (const Eigen::Vector3f& p : cloud) summary.cloud_bounds_m.extend(p.cast<double>());
  // A voxelised map turns every slope into a staircase of one-voxel risers, which the rule
  // would read as walls: risers of one voxel are tolerated as steps.
  summary.vertical_quantum_m =
      vertical_quantum_m ? *vertical_quantum_m : DetectVerticalQuantum(cloud);
  // The grid's size is known from the bounds: refuse an absurd one before any heavy work.
  Expected<GridGeometry> geometry = internal::AssessmentGrid(summary, config.grid);
  if (!geometry) return geometry.error();

  progress.BeginStage(AssessmentStage::kSorting, 1);
  internal::ColumnCloud sorted = internal::SortIntoColumns(*geometry, cloud, config.num_threads);
  internal::ThinColumns(&sorted, *geometry, config.num_threads);
  if (!progress.Advance(1)) return cancelled("while sorting the points");
  progress.BeginStage(AssessmentStage::kGroundFilter, geometry->size.y());
  if (Status s = internal::FilterValidGroundInColumns(
          &sorted, config.ground, geometry->resolution_m,
          internal::StepTolerance(summary.vertical_quantum_m), config.num_threads, &progress);
      !s) {
    return s.error();
  }
  for (const std::uint8_t v : sorted.valid) summary.valid_ground_points += v;
  summary.timings.ground_filter_s = stage.Lap();

  const FieldConfig field =
      FieldConfigForQuantum(config.field, summary.vertical_quantum_m, config.grid.resolution_m);
  progress.BeginStage(AssessmentStage::kSurfaces, geometry->LayerCellCount());
  Expected<SurfaceMap> surfaces =
      SurfaceMap::BuildFromColumns(*geometry, sorted, field, config.num_threads, &progress);
  if (!surfaces) return surfaces.error();
  model->surfaces_ = std::move(surfaces).value();
  summary.surface_count = model->surfaces_.surface_count();
  summary.valid_surface_count = model->surfaces_.valid_surface_count();
  summary.timings.surfaces_s = stage.Lap();

  Expected<TerrainFields> fields = internal::BuildTerrainFields(
      model->surfaces_, sorted, field, config.grid, config.num_threads, &progress);
  if (!fields) return fields.error();
  model->fields_ = std::move(fields).value();
  summary.timings.fields_s = stage.Lap();
  summary.timings.total_s = total.Lap();
  return std::shared_ptr<const TerrainModel>(std::move(model));
}

Expected<std::shared_ptr<const TerrainModel>> TerrainModel::FromParts(
    const AssessmentConfig& config, const AssessmentSummary& summary, SurfaceMap surfaces,
    TerrainFields fields) {
  const GridGeometry& a = surfaces.geometry();
  const GridGeometry& b = fields.geometry();
  if (a.size != b.size || a.origin_m != b.origin_m || a.resolution_m != b.resolution_m) {
    return Error{ErrorCode::kInvalidInput, "the surfaces and the fields lie on different grids"};
  }
  std::shared_ptr<TerrainModel> model(new TerrainModel());
  model->config_ = config;
  model->summary_ = summary;
  model->surfaces_ = std::move(surfaces);
  model->fields_ = std::move(fields);
  return std::shared_ptr<const TerrainModel>(std::move(model));
}

}  // namespace strata
