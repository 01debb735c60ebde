#include "assessment/terrain_fields_build.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "parallel_internal.hpp"
#include "strata/assessment/esdf.hpp"
#include "strata/assessment/safety_field.hpp"

namespace strata::internal {
namespace {

// Tiles are kTileColumns × kTileColumns columns: large enough that the halos (the distance
// cap and the diffusion kernel's reach, a few columns) add little work, small enough that a
// tile's dense scratch stays a few MB and two cores share the work evenly on small maps.
constexpr int kTileColumns = 64;

using LayerRange = std::pair<int, int>;  // [first, last] layers, inclusive.

Error TooManyCells() {
  return Error{ErrorCode::kResourceExhausted,
               "the map's field band needs more than 2^32 cells: use a coarser resolution"};
}

int LayerOf(const GridGeometry& g, double z) {
  const double layer = std::floor((z - g.origin_m.z()) / g.resolution_m);
  return static_cast<int>(std::clamp(layer, 0.0, static_cast<double>(g.size.z() - 1)));
}

// The band of column (ix, iy): for every valid surface of the column and its 8 neighbours, the
// layers from one below its ground to one above ground + band height, merged.
void BandOfColumn(const SurfaceMap& surfaces, double band_height_m, int ix, int iy,
                  std::vector<LayerRange>* ranges) {
  const GridGeometry& g = surfaces.geometry();
  ranges->clear();
  for (int y = std::max(0, iy - 1); y <= std::min(g.size.y() - 1, iy + 1); ++y) {
    for (int x = std::max(0, ix - 1); x <= std::min(g.size.x() - 1, ix + 1); ++x) {
      for (const ColumnSurface& s : surfaces.Column(x, y)) {
        if (!s.valid) continue;
        ranges->emplace_back(
            std::max(0, LayerOf(g, s.ground_z_m) - 1),
            std::min(g.size.z() - 1, LayerOf(g, s.ground_z_m + band_height_m) + 1));
      }
    }
  }
  std::sort(ranges->begin(), ranges->end());
  std::size_t merged = 0;
  for (const LayerRange& r : *ranges) {
    if (merged > 0 && r.first <= (*ranges)[merged - 1].second + 1) {
      (*ranges)[merged - 1].second = std::max((*ranges)[merged - 1].second, r.second);
    } else {
      (*ranges)[merged++] = r;
    }
  }
  ranges->resize(merged);
}

// Occupancy of the cells of `box`: a cell holding any point of the cloud.
void OccupancyInBox(const GridGeometry& g, const ColumnCloud& cloud, const CellBox& box,
                    std::vector<std::uint8_t>* occupied) {
  occupied->assign(static_cast<std::size_t>(box.CellCount()), 0);
  const Eigen::Vector3i n = box.size();
  for (int iy = box.min.y(); iy <= box.max.y(); ++iy) {
    for (int ix = box.min.x(); ix <= box.max.x(); ++ix) {
      for (const Eigen::Vector3f& p : cloud.Column(cloud.ColumnIndex(ix, iy))) {
        const int iz = ClampedLayer(g, p.z());
        if (iz < box.min.z()) continue;
        if (iz > box.max.z()) break;  // The column is sorted by height.
        (*occupied)[(ix - box.min.x()) +
                    std::int64_t{n.x()} *
                        ((iy - box.min.y()) + std::int64_t{n.y()} * (iz - box.min.z()))] = 1;
      }
    }
  }
}

template <typename T>
T Quantise(double value, double step) {
  const double q = std::round(value / step);
  return static_cast<T>(std::clamp(q, static_cast<double>(std::numeric_limits<T>::min()),
                                   static_cast<double>(std::numeric_limits<T>::max())));
}

}  // namespace

FieldReach FieldReachOf(const FieldConfig& field, const GridConfig& grid, double resolution_m) {
  FieldReach reach;
  // BandOfColumn reads the 8 neighbours; S' at a cell reads S within the kernel's reach, and
  // S at a cell reads the surfaces of its 4 neighbours (PoseGradientNorm).
  reach.surfaces = SafetyDiffusion(field, resolution_m).reach() + 1;
  reach.points = static_cast<int>(std::ceil(grid.distance_cap_m / resolution_m));
  return reach;
}

Expected<TerrainFields::Parts> BuildFieldParts(const SurfaceMap& surfaces, const ColumnCloud& cloud,
                                               const CellBox& window, const FieldConfig& field,
                                               const GridConfig& grid, int num_threads,
                                               ProgressReporter* progress) {
  num_threads = ResolveThreadCount(num_threads);
  const GridGeometry& g = surfaces.geometry();
  const int wx = window.max.x() - window.min.x() + 1;
  const int wy = window.max.y() - window.min.y() + 1;
  const std::int64_t columns = std::int64_t{wx} * wy;
  // Index of grid column (ix, iy) of the window in the parts' column index.
  const auto local = [&](int ix, int iy) {
    return (ix - window.min.x()) + std::int64_t{wx} * (iy - window.min.y());
  };
  TerrainFields::Parts parts;
  parts.geometry = g;
  parts.distance_cap_m = grid.distance_cap_m;
  parts.safety_background = field.VoidPenalty();
  // S and S' never exceed the void penalty: every term of S is capped by it, and S' averages S.
  parts.safety_step = parts.safety_background > 0 ? parts.safety_background / 65535.0 : 1.0;

  // The band's intervals: counted, then laid out (the band of a column is recomputed rather
  // than held for every column between the passes). An interval's offset first holds its cell
  // count; the running sum turns counts into offsets.
  const auto for_each_band = [&](const auto& use) {
#pragma omp parallel num_threads(num_threads)
    {
      std::vector<LayerRange> ranges;
#pragma omp for schedule(dynamic, 4096)
      for (std::int64_t c = 0; c < columns; ++c) {
        BandOfColumn(surfaces, grid.band_height_m, window.min.x() + static_cast<int>(c % wx),
                     window.min.y() + static_cast<int>(c / wx), &ranges);
        use(c, ranges);
      }
    }
  };
  parts.column_begin.assign(columns + 1, 0);
  for_each_band([&](std::int64_t c, const std::vector<LayerRange>& ranges) {
    parts.column_begin[c + 1] = static_cast<std::uint32_t>(ranges.size());
  });
  for (std::int64_t c = 0; c < columns; ++c) parts.column_begin[c + 1] += parts.column_begin[c];
  parts.intervals.resize(parts.column_begin.back() + std::size_t{1});
  for_each_band([&](std::int64_t c, const std::vector<LayerRange>& ranges) {
    TerrainFields::Interval* out = parts.intervals.data() + parts.column_begin[c];
    for (const LayerRange& r : ranges) {
      *out++ = {r.first, static_cast<std::uint32_t>(r.second - r.first + 1)};
    }
  });
  std::uint64_t cells = 0;
  for (TerrainFields::Interval& interval : parts.intervals) {
    const std::uint64_t count = interval.offset;
    if (cells > std::numeric_limits<std::uint32_t>::max()) return TooManyCells();
    interval.offset = static_cast<std::uint32_t>(cells);
    cells += count;
  }
  parts.distance.resize(cells);
  parts.safety.resize(cells);

  // Values, tile by tile: each tile computes S and d densely over its own band's layers plus
  // the halo its values depend on (the kernel's reach for S', the cap for d), and writes only
  // its own columns' values, so tiles run in parallel without sharing anything.
  const SafetyDiffusion diffusion(field, g.resolution_m);
  const int halo_d = FieldReachOf(field, grid, g.resolution_m).points;
  const int tiles_x = (wx + kTileColumns - 1) / kTileColumns;
  const int tiles_y = (wy + kTileColumns - 1) / kTileColumns;
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<LayerRange> layers;
    std::vector<std::uint8_t> occupied;
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t tile = 0; tile < std::int64_t{tiles_x} * tiles_y; ++tile) {
      if (progress != nullptr && progress->stopped()) continue;
      const int x0 = window.min.x() + static_cast<int>(tile % tiles_x) * kTileColumns;
      const int y0 = window.min.y() + static_cast<int>(tile / tiles_x) * kTileColumns;
      const int x1 = std::min(window.max.x() + 1, x0 + kTileColumns) - 1;
      const int y1 = std::min(window.max.y() + 1, y0 + kTileColumns) - 1;
      // The tile's stored layers, grouped into clusters that are transformed separately: a
      // gap wider than two halos means nothing of one cluster reaches the other (a stray
      // level far above costs its own small block, not the air in between).
      layers.clear();
      for (int iy = y0; iy <= y1; ++iy) {
        for (int ix = x0; ix <= x1; ++ix) {
          const std::int64_t c = local(ix, iy);
          for (std::uint32_t k = parts.column_begin[c]; k < parts.column_begin[c + 1]; ++k) {
            const int first = parts.intervals[k].first_layer;
            layers.emplace_back(first, first +
                                           static_cast<int>(parts.intervals[k + 1].offset -
                                                            parts.intervals[k].offset) -
                                           1);
          }
        }
      }
      std::sort(layers.begin(), layers.end());
      std::size_t begin = 0;
      while (begin < layers.size()) {
        int z0 = layers[begin].first, z1 = layers[begin].second;
        std::size_t end = begin + 1;
        for (; end < layers.size() && layers[end].first <= z1 + 2 * halo_d + 1; ++end) {
          z1 = std::max(z1, layers[end].second);
        }
        begin = end;
        const CellBox core{{x0, y0, z0}, {x1, y1, z1}};
        const CellBox safety_box = core.Grown({diffusion.reach(), diffusion.reach(), 0}, g);
        const ScalarGrid penalty = ComputeSafetyPenalty(surfaces, field, safety_box);
        const CellBox distance_box = core.Grown({halo_d, halo_d, halo_d}, g);
        OccupancyInBox(g, cloud, distance_box, &occupied);
        const ScalarGrid distance =
            BuildSignedDistanceField(distance_box.Geometry(g), occupied, grid.distance_cap_m,
                                     /*num_threads=*/1);  // The tiles share the threads.
        for (int iy = y0; iy <= y1; ++iy) {
          for (int ix = x0; ix <= x1; ++ix) {
            const std::int64_t c = local(ix, iy);
            for (std::uint32_t k = parts.column_begin[c]; k < parts.column_begin[c + 1]; ++k) {
              const TerrainFields::Interval& interval = parts.intervals[k];
              if (interval.first_layer < z0 || interval.first_layer > z1) continue;
              const std::uint32_t count = parts.intervals[k + 1].offset - interval.offset;
              for (std::uint32_t j = 0; j < count; ++j) {
                const Eigen::Vector3i cell(ix, iy, interval.first_layer + static_cast<int>(j));
                const std::size_t out = interval.offset + j;
                parts.distance[out] = Quantise<std::int16_t>(
                    distance.values()[distance_box.Index(cell)], TerrainFields::kDistanceStepM);
                parts.safety[out] = Quantise<std::uint16_t>(
                    diffusion.At(penalty, safety_box, g.size, cell), parts.safety_step);
              }
            }
          }
        }
      }
      if (progress != nullptr) progress->Advance(1);
    }
  }
  if (progress != nullptr && progress->stopped()) {
    return Error{ErrorCode::kCancelled, "terrain assessment cancelled while computing the fields"};
  }
  return parts;
}

std::int64_t FieldTileCount(const CellBox& window) {
  const Eigen::Vector3i size = window.size();
  return std::int64_t{(size.x() + kTileColumns - 1) / kTileColumns} *
         ((size.y() + kTileColumns - 1) / kTileColumns);
}

Expected<TerrainFields> BuildTerrainFields(const SurfaceMap& surfaces, const ColumnCloud& cloud,
                                           const FieldConfig& field, const GridConfig& grid,
                                           int num_threads, ProgressReporter* progress) {
  // Chunk by chunk: a column's values do not depend on the window.
  const GridGeometry& g = surfaces.geometry();
  std::int64_t tiles = 0;
  for (int k = 0; k < ChunkCount(g); ++k) tiles += FieldTileCount(ChunkColumns(g, k));
  if (progress != nullptr) progress->BeginStage(AssessmentStage::kFields, tiles);
  TerrainFields::Scalars scalars;
  std::vector<TerrainFields::Chunk> chunks;
  chunks.reserve(ChunkCount(g));
  std::uint64_t cells = 0;
  for (int k = 0; k < ChunkCount(g); ++k) {
    Expected<TerrainFields::Parts> parts =
        BuildFieldParts(surfaces, cloud, ChunkColumns(g, k), field, grid, num_threads, progress);
    if (!parts) return parts.error();
    cells += parts->distance.size();
    if (cells > std::numeric_limits<std::uint32_t>::max()) return TooManyCells();
    scalars = *parts;
    chunks.push_back(std::make_shared<const TerrainFields::Runs>(
        std::move(static_cast<TerrainFields::Runs&>(*parts))));
  }
  return TerrainFields::FromChunks(scalars, std::move(chunks));
}

}  // namespace strata::internal
