#include "offline/map_source.hpp"

#include <charconv>
#include <chrono>

#include "strata/scenes/scenes.hpp"

namespace strata::offline {

Expected<LoadedCloud> LoadMapSource(const std::string& source) {
  constexpr std::string_view kScenePrefix = "scene:";
  if (!source.starts_with(kScenePrefix)) return LoadPointCloud(source);

  std::string name = source.substr(kScenePrefix.size());
  std::uint32_t seed = 1;
  if (const auto colon = name.find(':'); colon != std::string::npos) {
    const std::string seed_text = name.substr(colon + 1);
    const auto [end, ec] =
        std::from_chars(seed_text.data(), seed_text.data() + seed_text.size(), seed);
    if (ec != std::errc() || end != seed_text.data() + seed_text.size()) {
      return Error{ErrorCode::kInvalidInput,
                   "scene seed '" + seed_text + "' is not an unsigned integer"};
    }
    name.resize(colon);
  }
  Expected<PointCloud> cloud = GenerateScene(name, seed);
  if (!cloud) return cloud.error();
  return SanitizeCloud(std::move(cloud).value());
}

Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  Expected<LoadedCloud> cloud = LoadMapSource(source);
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
