#include "offline/assessed_map.hpp"

#include <chrono>

#include "strata/scenes/map_source.hpp"

namespace strata::offline {

Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  Expected<MapSource> parsed = ParseMapSource(source);
  if (!parsed) return parsed.error();
  Expected<LoadedCloud> cloud = LoadMapSource(*parsed);
  if (!cloud) return cloud.error();
  AssessedMap map;
  map.load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  map.raw_point_count = cloud->raw_point_count;
  map.dropped_nonfinite = cloud->dropped_nonfinite;
  auto model = TerrainModel::Assess(cloud->points, config);
  if (!model) return model.error();
  map.model = std::move(model).value();
  return map;
}

}  // namespace strata::offline
