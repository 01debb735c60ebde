#include "strata/scenes/map_source.hpp"

#include <charconv>

#include "strata/scenes/scenes.hpp"

namespace strata {

Expected<SceneSource> ParseSceneSource(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return Error{ErrorCode::kInvalidInput,
                 "'" + std::string(text) + "' is not scene:NAME[:SEED]: " + why};
  };
  if (!text.starts_with(kScenePrefix)) return bad("it does not start with 'scene:'");
  std::string_view rest = text.substr(kScenePrefix.size());
  SceneSource scene;
  if (const std::size_t colon = rest.find(':'); colon != std::string_view::npos) {
    const std::string_view seed_text = rest.substr(colon + 1);
    const char* end = seed_text.data() + seed_text.size();
    const auto [used, ec] = std::from_chars(seed_text.data(), end, scene.seed);
    if (seed_text.empty() || ec != std::errc() || used != end) {
      return bad("the seed must be an integer in [0, 4294967295]");
    }
    rest = rest.substr(0, colon);
  }
  if (rest.empty()) return bad("NAME is missing");
  scene.name = std::string(rest);
  return scene;
}

Expected<MapSource> ParseMapSource(std::string_view text) {
  if (!text.starts_with(kScenePrefix)) return MapSource(FileSource{std::string(text)});
  Expected<SceneSource> scene = ParseSceneSource(text);
  if (!scene) return scene.error();
  return MapSource(std::move(scene).value());
}

Expected<LoadedCloud> LoadMapSource(const MapSource& source, const CloudLoadLimits& limits) {
  if (const auto* file = std::get_if<FileSource>(&source)) {
    return LoadPointCloud(file->path, limits);
  }
  const auto& scene = std::get<SceneSource>(source);
  Expected<PointCloud> cloud = GenerateScene(scene.name, scene.seed);
  if (!cloud) return cloud.error();
  return SanitizeCloud(std::move(cloud).value(), limits);
}

}  // namespace strata
