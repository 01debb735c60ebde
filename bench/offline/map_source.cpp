#include "offline/map_source.hpp"

#include <charconv>

#include "strata/scenes.hpp"

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

}  // namespace strata::offline
