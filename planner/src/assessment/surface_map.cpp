#include "strata/assessment/surface_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "assessment/assessment_progress.hpp"
#include "assessment/column_cloud.hpp"
#include "assessment/surface_map_build.hpp"
#include "column_chunks_internal.hpp"
#include "parallel_internal.hpp"
#include "strata/assessment/plane_fit.hpp"

namespace strata {
namespace {

// Progress and cancellation granularity of the plane fits [columns].
constexpr std::int64_t kColumnsPerUnit = 4096;

using internal::ClampedLayer;
using internal::ColumnCloud;

// Calls emit(run) for every run of vertically adjacent occupied cells in one sorted column.
template <typename Emit>
void ForEachRun(const GridGeometry& g, const ColumnCloud& sorted, std::int64_t column, Emit emit) {
  const std::uint32_t first = sorted.begin[column];
  const std::uint32_t last = sorted.begin[column + 1];
  std::uint32_t run_start = first;
  while (run_start < last) {
    int top = ClampedLayer(g, sorted.points[run_start].z());
    const int bottom = top;
    std::uint32_t k = run_start + 1;
    for (; k < last; ++k) {
      const int layer = ClampedLayer(g, sorted.points[k].z());
      if (layer > top + 1) break;
      top = std::max(top, layer);
    }
    ColumnSurface s;
    s.bottom_layer = bottom;
    s.top_layer = top;
    float highest = -std::numeric_limits<float>::infinity();
    float highest_valid = highest;
    for (std::uint32_t j = k; j-- > run_start;) {
      if (ClampedLayer(g, sorted.points[j].z()) != top) break;
      highest = std::max(highest, sorted.points[j].z());
      if (sorted.valid[j]) highest_valid = std::max(highest_valid, sorted.points[j].z());
    }
    s.valid = std::isfinite(highest_valid);
    s.ground_z_m = s.valid ? highest_valid : highest;
    // The next run's lowest point caps the clearance; set by the caller once it is known.
    s.clearance_m = std::numeric_limits<float>::infinity();
    emit(s, sorted.points[run_start].z());
    run_start = k;
  }
}

// Gathers the points of the vertical cylinder (horizontal `radius`, `half_height` above and
// below) around `centre` from the columns within `reach` of (ix, iy). With `column_tops`,
// only the highest run top (a point with no point in the voxel above it) of each column: a
// wall's points are not tops, so they cannot tilt the fit of the ground beside it.
void GatherNeighbourhood(const GridGeometry& g, const ColumnCloud& sorted, int ix, int iy,
                         int reach, const Eigen::Vector3f& centre, float radius, float half_height,
                         bool column_tops, std::vector<Eigen::Vector3f>* out) {
  out->clear();
  const float radius_sq = radius * radius;
  for (int y = std::max(0, iy - reach); y <= std::min(g.size.y() - 1, iy + reach); ++y) {
    for (int x = std::max(0, ix - reach); x <= std::min(g.size.x() - 1, ix + reach); ++x) {
      const std::int64_t c = sorted.ColumnIndex(x, y);
      const auto begin = sorted.points.begin() + sorted.begin[c];
      const auto end = sorted.points.begin() + sorted.begin[c + 1];
      auto it = std::lower_bound(begin, end, centre.z() - half_height,
                                 [](const Eigen::Vector3f& p, float z) { return p.z() < z; });
      const Eigen::Vector3f* top = nullptr;
      for (; it != end && it->z() <= centre.z() + half_height; ++it) {
        if ((*it - centre).head<2>().squaredNorm() > radius_sq) continue;
        if (column_tops) {
          const auto next = it + 1;
          if (next == end || ClampedLayer(g, next->z()) > ClampedLayer(g, it->z()) + 1) top = &*it;
        } else {
          out->push_back(*it);
        }
      }
      if (top != nullptr) out->push_back(*top);
    }
  }
}

// The fitted plane's height above the column centre. The inliers' centroid drifts off the
// centre wherever the patch is cut (by an edge, or by the height band on a slope), and on a
// voxel staircase it jumps with each tread; the plane itself is the smooth ground. A plane
// too steep to stand on keeps the centroid's height, where the extrapolation would be wild.
double PlaneHeightAt(const PlaneFit& fit, const Eigen::Vector3d& centre_xy) {
  constexpr double kMinNormalZ = 0.5;  // Planes up to 60°.
  if (fit.normal.z() < kMinNormalZ) return fit.center_m.z();
  const Eigen::Vector2d offset = centre_xy.head<2>() - fit.center_m.head<2>();
  return fit.center_m.z() - fit.normal.head<2>().dot(offset) / fit.normal.z();
}

}  // namespace

SurfaceMap SurfaceMap::Build(const GridGeometry& geometry, const PointCloud& cloud,
                             const std::vector<std::uint8_t>& valid_ground,
                             const FieldConfig& field, int num_threads) {
  std::vector<std::uint32_t> source;
  ColumnCloud sorted = internal::SortIntoColumns(geometry, cloud, num_threads, &source);
  for (std::size_t k = 0; k < source.size(); ++k) sorted.valid[k] = valid_ground[source[k]];
  return std::move(BuildFromColumns(geometry, sorted, field, num_threads, nullptr)).value();
}

namespace {

// Why `s`, the surfaces of `columns` columns of a grid of `layers` layers, are inconsistent,
// or empty when they are not.
std::string Inconsistency(const ColumnSurfaces& s, std::int64_t columns, int layers) {
  const std::vector<std::uint32_t>& column_begin = s.column_begin;
  if (static_cast<std::int64_t>(column_begin.size()) != columns + 1 || column_begin.front() != 0 ||
      column_begin.back() != s.surfaces.size()) {
    return "the column index does not match the grid and the surfaces";
  }
  for (std::int64_t c = 0; c < columns; ++c) {
    // Past the surfaces, the loop below would read beyond them.
    if (column_begin[c + 1] < column_begin[c] || column_begin[c + 1] > s.surfaces.size()) {
      return "the column index is not monotone";
    }
    std::int32_t previous_top = -1;
    float previous_ground = -std::numeric_limits<float>::infinity();
    for (std::uint32_t k = column_begin[c]; k < column_begin[c + 1]; ++k) {
      const ColumnSurface& surface = s.surfaces[k];
      if (surface.bottom_layer <= previous_top || surface.top_layer < surface.bottom_layer ||
          surface.top_layer >= layers) {
        return "a surface's layers are unsorted or outside the grid";
      }
      if (!std::isfinite(surface.ground_z_m) || !std::isfinite(surface.plane_center_z_m) ||
          !(surface.tilt_rad >= 0 && surface.tilt_rad <= std::numbers::pi / 2 + 1e-6) ||
          !(surface.clearance_m >= 0)) {
        return "a surface's height, tilt or clearance is not a number in range";
      }
      // Each ground lies in its surface's top cell, so they ascend with the layers; the
      // terrain queries stop at the first ground above a point (terrain_query.cpp).
      if (surface.ground_z_m < previous_ground) {
        return "a column's ground heights do not ascend with its surfaces";
      }
      previous_top = surface.top_layer;
      previous_ground = surface.ground_z_m;
    }
  }
  return {};
}

Error InconsistentSurfaces(const std::string& what) {
  return Error{ErrorCode::kInvalidInput, "surfaces are inconsistent: " + what};
}

int MostValidLevels(const ColumnSurfaces& s) {
  int most = 0;
  for (std::size_t c = 0; c + 1 < s.column_begin.size(); ++c) {
    int valid = 0;
    for (std::uint32_t k = s.column_begin[c]; k < s.column_begin[c + 1]; ++k) {
      valid += s.surfaces[k].valid;
    }
    most = std::max(most, valid);
  }
  return most;
}

bool IsEmptyGrid(const GridGeometry& geometry) {
  return !(geometry.resolution_m > 0) || (geometry.size.array() < 1).any();
}

}  // namespace

Expected<SurfaceMap> SurfaceMap::BuildFromColumns(const GridGeometry& geometry,
                                                  const internal::ColumnCloud& sorted,
                                                  const FieldConfig& field, int num_threads,
                                                  internal::ProgressReporter* progress) {
  SurfaceMap map;
  map.geometry_ = geometry;
  for (int k = 0; k < ChunkCount(geometry); ++k) {
    Expected<ColumnSurfaces> built = internal::BuildColumnSurfaces(
        geometry, sorted, ChunkColumns(geometry, k), field, num_threads, progress);
    if (!built) return built.error();
    const int levels = MostValidLevels(*built);
    map.Append(std::make_shared<const ColumnSurfaces>(std::move(built).value()), levels);
  }
  return map;
}

Expected<SurfaceMap> SurfaceMap::FromParts(const GridGeometry& geometry,
                                           std::vector<std::uint32_t> column_begin,
                                           std::vector<ColumnSurface> surfaces) {
  if (IsEmptyGrid(geometry)) return InconsistentSurfaces("empty grid");
  ColumnSurfaces whole{std::move(column_begin), std::move(surfaces)};
  if (std::string why = Inconsistency(whole, geometry.LayerCellCount(), geometry.size.z());
      !why.empty()) {
    return InconsistentSurfaces(why);
  }
  SurfaceMap map;
  map.geometry_ = geometry;
  const std::int64_t nx = geometry.size.x();
  for (int k = 0; k < ChunkCount(geometry); ++k) {
    const std::int64_t first = nx * k * kChunkRows;
    const std::int64_t end = first + nx * ChunkRowCount(geometry, k);
    ColumnSurfaces chunk;
    internal::Reserve(internal::SizeOfColumns(whole, first, end), &chunk);
    internal::AppendColumns(whole, first, end, &chunk);
    internal::FinishColumns(&chunk);
    const int levels = MostValidLevels(chunk);
    map.Append(std::make_shared<const ColumnSurfaces>(std::move(chunk)), levels);
  }
  return map;
}

Expected<SurfaceMap> SurfaceMap::FromChunks(const GridGeometry& geometry, std::vector<Chunk> chunks,
                                            const SurfaceMap* checked) {
  if (IsEmptyGrid(geometry)) return InconsistentSurfaces("empty grid");
  if (static_cast<int>(chunks.size()) != ChunkCount(geometry)) {
    return InconsistentSurfaces("the chunks do not cover the grid's rows");
  }
  const bool same_grid = checked != nullptr && checked->geometry_.size == geometry.size;
  SurfaceMap map;
  map.geometry_ = geometry;
  for (int k = 0; k < ChunkCount(geometry); ++k) {
    if (chunks[k] == nullptr) return InconsistentSurfaces("a chunk is missing");
    if (same_grid && checked->chunks_[k] == chunks[k]) {
      map.Append(std::move(chunks[k]), checked->chunk_levels_[k]);
      continue;
    }
    if (std::string why =
            Inconsistency(*chunks[k], geometry.size.x() * std::int64_t{ChunkRowCount(geometry, k)},
                          geometry.size.z());
        !why.empty()) {
      return InconsistentSurfaces(why);
    }
    const int levels = MostValidLevels(*chunks[k]);
    map.Append(std::move(chunks[k]), levels);
  }
  return map;
}

void SurfaceMap::Append(Chunk chunk, int levels) {
  if (chunks_.empty()) {
    chunks_.reserve(ChunkCount(geometry_));
    chunk_levels_.reserve(ChunkCount(geometry_));
  }
  surface_count_ += chunk->surfaces.size();
  chunks_.push_back(std::move(chunk));
  chunk_levels_.push_back(levels);
}

int SurfaceMap::max_valid_levels() const {
  return chunk_levels_.empty() ? 0 : *std::max_element(chunk_levels_.begin(), chunk_levels_.end());
}

ColumnSurfaces SurfaceMap::ToParts() const {
  ColumnSurfaces whole;
  for (const Chunk& chunk : chunks_) {
    internal::AppendColumns(*chunk, 0, std::ssize(chunk->column_begin) - 1, &whole);
  }
  internal::FinishColumns(&whole);
  return whole;
}

std::size_t SurfaceMap::valid_surface_count() const {
  std::size_t count = 0;
  for (const Chunk& chunk : chunks_) {
    count += static_cast<std::size_t>(std::count_if(chunk->surfaces.begin(), chunk->surfaces.end(),
                                                    [](const auto& s) { return s.valid; }));
  }
  return count;
}

namespace {

std::size_t ChunkBytes(const ColumnSurfaces& chunk) {
  return chunk.column_begin.capacity() * sizeof(std::uint32_t) +
         chunk.surfaces.capacity() * sizeof(ColumnSurface);
}

}  // namespace

std::size_t SurfaceMap::MemoryBytes() const {
  std::size_t bytes = chunks_.capacity() * sizeof(Chunk) + chunk_levels_.capacity() * sizeof(int);
  for (const Chunk& chunk : chunks_) bytes += ChunkBytes(*chunk);
  return bytes;
}

std::size_t SurfaceMap::MemoryBytesBeyond(const SurfaceMap& other) const {
  if (other.chunks_.size() != chunks_.size()) return MemoryBytes();
  std::size_t bytes = chunks_.capacity() * sizeof(Chunk) + chunk_levels_.capacity() * sizeof(int);
  for (std::size_t k = 0; k < chunks_.size(); ++k) {
    if (chunks_[k] != other.chunks_[k]) bytes += ChunkBytes(*chunks_[k]);
  }
  return bytes;
}

const ColumnSurface* SurfaceMap::SurfaceBelow(int ix, int iy, int iz) const {
  const ColumnSurface* below = nullptr;
  for (const ColumnSurface& s : Column(ix, iy)) {
    if (s.bottom_layer > iz) break;
    if (s.top_layer > iz) return nullptr;  // Inside this run's obstacle.
    below = &s;
  }
  return below;
}

namespace internal {

int PlaneFitReach(const FieldConfig& field, double resolution_m) {
  return static_cast<int>(std::ceil(static_cast<float>(field.plane_fit_radius_m) / resolution_m));
}

Expected<ColumnSurfaces> BuildColumnSurfaces(const GridGeometry& geometry,
                                             const ColumnCloud& sorted, const CellBox& window,
                                             const FieldConfig& field, int num_threads,
                                             ProgressReporter* progress) {
  num_threads = ResolveThreadCount(num_threads);
  const GridGeometry& g = geometry;
  const int wx = window.max.x() - window.min.x() + 1;
  const std::int64_t columns = std::int64_t{wx} * (window.max.y() - window.min.y() + 1);
  // The grid column of the window's column c.
  const auto grid_column = [&](std::int64_t c) {
    return Eigen::Vector2i(window.min.x() + static_cast<int>(c % wx),
                           window.min.y() + static_cast<int>(c / wx));
  };

  ColumnSurfaces out;
  out.column_begin.assign(columns + 1, 0);
#pragma omp parallel for schedule(dynamic, 1024) num_threads(num_threads)
  for (std::int64_t c = 0; c < columns; ++c) {
    const Eigen::Vector2i column = grid_column(c);
    std::uint32_t runs = 0;
    ForEachRun(g, sorted, sorted.ColumnIndex(column.x(), column.y()),
               [&](const ColumnSurface&, float) { ++runs; });
    out.column_begin[c + 1] = runs;
  }
  for (std::int64_t c = 0; c < columns; ++c) out.column_begin[c + 1] += out.column_begin[c];
  out.surfaces.resize(out.column_begin.back());

  const float fit_radius = static_cast<float>(field.plane_fit_radius_m);
  const float fit_half_height = static_cast<float>(field.plane_fit_half_height_m);
  const int reach = PlaneFitReach(field, g.resolution_m);
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<Eigen::Vector3f> patch;
    std::vector<float> weights;
    LocalPlaneFitter fitter(field.plane_inlier_distance_m, field.plane_ransac_iterations);
#pragma omp for schedule(dynamic, 256)
    for (std::int64_t c = 0; c < columns; ++c) {
      // An OpenMP loop cannot break: once stopped, every remaining column is skipped.
      if (progress != nullptr) {
        if (progress->stopped()) continue;
        if (c % kColumnsPerUnit == 0) progress->Advance(std::min(kColumnsPerUnit, columns - c));
      }
      const Eigen::Vector2i column = grid_column(c);
      const int ix = column.x();
      const int iy = column.y();
      ColumnSurface* surface = out.surfaces.data() + out.column_begin[c];
      ColumnSurface* previous = nullptr;
      ForEachRun(g, sorted, sorted.ColumnIndex(ix, iy),
                 [&](const ColumnSurface& s, float run_min_z) {
                   if (previous != nullptr)
                     previous->clearance_m = run_min_z - previous->ground_z_m;
                   *surface = s;
                   previous = surface++;
                 });
      const Eigen::Vector3d centre_xy = g.CellCenter({ix, iy, 0});
      for (ColumnSurface* s = out.surfaces.data() + out.column_begin[c]; s != surface; ++s) {
        const Eigen::Vector3f centre(static_cast<float>(centre_xy.x()),
                                     static_cast<float>(centre_xy.y()), s->ground_z_m);
        GatherNeighbourhood(g, sorted, ix, iy, reach, centre, fit_radius, fit_half_height,
                            field.plane_fit_column_tops, &patch);
        if (field.plane_fit_column_tops) {
          // Voxel staircases: a hard disc edge makes the fit jump as a riser enters or leaves
          // it; a smooth taper (biweight in the horizontal distance) makes it glide.
          weights.clear();
          for (const Eigen::Vector3f& p : patch) {
            const float u = (p - centre).head<2>().squaredNorm() / (fit_radius * fit_radius);
            weights.push_back(std::max(1e-3f, (1 - u) * (1 - u)));
          }
        }
        const PlaneFit fit =
            fitter.Fit(patch, field.plane_fit_column_tops ? std::span<const float>(weights)
                                                          : std::span<const float>());
        if (fit.inlier_count >= 3) {
          s->tilt_rad = static_cast<float>(fit.tilt_rad);
          s->plane_center_z_m = static_cast<float>(PlaneHeightAt(fit, centre_xy));
        } else {
          // A lone point or a thin edge: nothing to stand on, so the steepest tilt.
          s->tilt_rad = static_cast<float>(std::numbers::pi / 2);
          s->plane_center_z_m = s->ground_z_m;
        }
      }
    }
  }
  if (progress != nullptr && progress->stopped()) {
    return Error{ErrorCode::kCancelled, "terrain assessment cancelled while fitting surfaces"};
  }
  return out;
}

}  // namespace internal

}  // namespace strata
