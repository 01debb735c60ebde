#include "rpc/map_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <string>

#include <fmt/format.h>

namespace strata::server {
namespace {

// One column surface of a block, before merging.
struct Entry {
  float z_m;
  bool ground;
  float safety;
  std::int32_t component;
};

// Display precision: millimetres and thousandths also print short in the JSON mapping.
float Round(double value, double step) {
  return static_cast<float>(std::round(value / step) * step);
}

}  // namespace

Expected<MapGeometryData> ExtractMapGeometry(const TerrainModel& model,
                                             const GeometryRequest& request,
                                             const std::function<bool()>& should_stop) {
  const int stride = request.stride;
  if (stride < 1 || stride > kMaxGeometryStride) {
    return Error{
        ErrorCode::kInvalidConfig,
        fmt::format("stride = {} is out of range: must be in [1, {}]", stride, kMaxGeometryStride),
        "stride"};
  }
  if (request.graph != nullptr && &request.graph->model() != &model) {
    return Error{ErrorCode::kInvalidConfig, "the graph was built on another terrain model"};
  }
  if (request.include_safety &&
      !(std::isfinite(request.safety_height_m) && request.safety_height_m > 0)) {
    return Error{ErrorCode::kInvalidConfig, "safety_height_m must be > 0 and finite",
                 "safety_height_m"};
  }
  const GridGeometry& grid = model.grid();
  const SurfaceMap& surfaces = model.surfaces();
  MapGeometryData data;
  data.stride = stride;
  data.nx = (grid.size.x() + stride - 1) / stride;
  data.ny = (grid.size.y() + stride - 1) / stride;
  data.resolution_m = grid.resolution_m;
  data.origin_m = grid.origin_m.head<2>();

  std::vector<Entry> block;
  std::vector<std::int32_t> node_of_surface;
  for (int cy = 0; cy < data.ny; ++cy) {
    if (should_stop && should_stop()) {
      return Error{ErrorCode::kCancelled, "stopped while extracting the map's geometry"};
    }
    for (int cx = 0; cx < data.nx; ++cx) {
      block.clear();
      for (int iy = cy * stride; iy < std::min((cy + 1) * stride, grid.size.y()); ++iy) {
        for (int ix = cx * stride; ix < std::min((cx + 1) * stride, grid.size.x()); ++ix) {
          const std::span<const ColumnSurface> column = surfaces.Column(ix, iy);
          if (request.graph != nullptr) {
            node_of_surface.assign(column.size(), -1);
            for (const std::int32_t node : request.graph->ColumnNodes(ix, iy)) {
              const auto index = &request.graph->surface(node) - column.data();
              if (index >= 0 && static_cast<std::size_t>(index) < column.size()) {
                node_of_surface[static_cast<std::size_t>(index)] = node;
              }
            }
          }
          for (std::size_t i = 0; i < column.size(); ++i) {
            const ColumnSurface& surface = column[i];
            Entry entry{surface.ground_z_m, surface.valid, 0.0F, -1};
            if (request.include_safety && surface.valid) {
              const Eigen::Vector3d centre = grid.CellCenter({ix, iy, 0});
              entry.safety = static_cast<float>(model.SafetyPenalty(
                  {centre.x(), centre.y(), surface.ground_z_m + request.safety_height_m}));
            }
            if (request.graph != nullptr && node_of_surface[i] >= 0) {
              entry.component = request.graph->component(node_of_surface[i]);
            }
            block.push_back(entry);
          }
        }
      }
      if (stride > 1) {
        std::sort(block.begin(), block.end(),
                  [](const Entry& a, const Entry& b) { return a.z_m < b.z_m; });
      }
      // Emits the surfaces of this cell, lowest first, merging runs of entries less than
      // kMergeGapM apart when the cell spans several columns.
      int ground_levels = 0;
      std::size_t begin = 0;
      while (begin < block.size()) {
        std::size_t end = begin + 1;
        while (stride > 1 && end < block.size() &&
               block[end].z_m - block[end - 1].z_m <= kMergeGapM) {
          ++end;
        }
        Entry merged{block[begin].z_m, false, 0.0F, -1};
        for (std::size_t i = begin; i < end; ++i) {
          const Entry& e = block[i];
          if (e.ground && !merged.ground) merged = Entry{e.z_m, true, 0.0F, -1};
          if (e.ground != merged.ground) continue;  // Ground outranks obstacle tops.
          merged.z_m = std::max(merged.z_m, e.z_m);
          merged.safety = std::max(merged.safety, e.safety);
          if (e.component >= 0) merged.component = e.component;  // The highest one's.
        }
        const auto cell = static_cast<std::uint32_t>(cx + data.nx * cy);
        if (merged.ground) {
          data.ground_cell.push_back(cell);
          data.ground_z_m.push_back(Round(merged.z_m, 1e-3));
          data.ground_level.push_back(static_cast<std::uint32_t>(ground_levels++));
          if (request.include_safety) data.ground_safety.push_back(Round(merged.safety, 1e-3));
          if (request.graph != nullptr) data.ground_component.push_back(merged.component);
        } else {
          data.obstacle_cell.push_back(cell);
          data.obstacle_z_m.push_back(Round(merged.z_m, 1e-3));
          data.obstacle_level.push_back(static_cast<std::uint32_t>(std::max(0, ground_levels - 1)));
        }
        begin = end;
      }
      data.max_levels = std::max(data.max_levels, ground_levels);
    }
  }
  return data;
}

int EstimateGeometryStride(const TerrainModel& model, std::uint64_t max_bytes,
                           double bytes_per_surface) {
  const double needed = static_cast<double>(model.surfaces().surface_count()) * bytes_per_surface;
  if (max_bytes == 0) return kMaxGeometryStride;
  const double ratio = needed / static_cast<double>(max_bytes);
  if (ratio <= 1) return 1;
  return std::clamp(static_cast<int>(std::ceil(std::sqrt(ratio))), 1, kMaxGeometryStride);
}

}  // namespace strata::server
