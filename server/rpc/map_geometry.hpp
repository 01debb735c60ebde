#pragma once
/// The surfaces of an assessed map for display (MapService.GetMapGeometry, the web viewer):
/// the column surfaces, merged over blocks of stride x stride columns on large maps, with
/// their level, their kind (ground or obstacle), S' and, given a robot's graph, its connected
/// components. Planner types only: proto_convert.hpp turns the result into a MapGeometry.
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/status.hpp"

namespace strata::server {

/// Most grid columns per display cell along x and y [-].
inline constexpr int kMaxGeometryStride = 256;

/// What to extract.
struct GeometryRequest {
  /// Grid columns per display cell along x and along y [-], in [1, kMaxGeometryStride].
  int stride = 1;
  /// Read S' at safety_height_m above every ground surface.
  bool include_safety = false;
  /// Height above the ground S' is read at [m] (a robot's reference height), > 0.
  double safety_height_m = 0.3;
  /// A robot's graph on the same model: label each surface with its component. May be null.
  const SurfaceGraph* graph = nullptr;
};

/// The surfaces, in parallel arrays (the MapGeometry message says what each means): ground and
/// obstacle tops, each ordered by display cell, then lowest first; heights to the millimetre
/// and S' to 1e-3 (display precision, which the JSON mapping also prints short).
struct MapGeometryData {
  int stride = 1;
  int nx = 0;  ///< Display cells along x [-].
  int ny = 0;  ///< Display cells along y [-].
  int max_levels = 0;
  double resolution_m = 0;
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  std::vector<std::uint32_t> ground_cell;
  std::vector<float> ground_z_m;
  std::vector<std::uint32_t> ground_level;
  std::vector<float> ground_safety;            ///< With include_safety.
  std::vector<std::int32_t> ground_component;  ///< With a graph; -1 where it cannot stand.
  std::vector<std::uint32_t> obstacle_cell;
  std::vector<float> obstacle_z_m;
  std::vector<std::uint32_t> obstacle_level;
};

/// Heights within this of each other [m] are one level when columns are merged (as
/// SurfaceGraph::kLevelGapM tells levels apart).
inline constexpr double kMergeGapM = SurfaceGraph::kLevelGapM;

/// The surfaces of `model` at `request.stride`. In a block of several columns, the columns'
/// surfaces sorted by height are merged where less than kMergeGapM apart: ground when any of
/// them is, at the highest ground (or the highest top), with the largest S' and the component
/// of the highest surface the robot can stand on. At stride 1 every column surface is its own.
/// Fails with kInvalidConfig for a stride out of range or a graph of another model, and with
/// kCancelled when `should_stop` (may be empty; polled every row of display cells) returns
/// true.
Expected<MapGeometryData> ExtractMapGeometry(const TerrainModel& model,
                                             const GeometryRequest& request,
                                             const std::function<bool()>& should_stop = {});

/// A first guess of the smallest stride at which `model`'s surfaces, `bytes_per_surface` each,
/// take at most `max_bytes`: its column surfaces spread evenly, s x s columns merged into one
/// (sparse maps merge less, so the caller checks the real size), in [1, kMaxGeometryStride].
int EstimateGeometryStride(const TerrainModel& model, std::uint64_t max_bytes,
                           double bytes_per_surface);

}  // namespace strata::server
