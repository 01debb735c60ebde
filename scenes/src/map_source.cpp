#include "strata/scenes/map_source.hpp"

#include <charconv>
#include <cmath>
#include <optional>
#include <vector>

namespace strata {

Expected<SceneSource> ParseSceneSource(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    std::string message = "'";
    message.append(text).append("' is not scene:NAME[:SEED][:size_m=M][:spacing_m=M]: ");
    return Error{ErrorCode::kInvalidInput, message.append(why)};
  };
  if (!text.starts_with(kScenePrefix)) return bad("it does not start with 'scene:'");
  // NAME, then the parts after it, split at every ':'.
  const std::string_view rest = text.substr(kScenePrefix.size());
  std::vector<std::string_view> parts;
  for (std::size_t start = 0;;) {
    const std::size_t colon = rest.find(':', start);
    parts.push_back(rest.substr(start, colon - start));
    if (colon == std::string_view::npos) break;
    start = colon + 1;
  }
  SceneSource scene;
  scene.name = std::string(parts[0]);
  if (scene.name.empty()) return bad("NAME is missing");
  for (std::size_t i = 1; i < parts.size(); ++i) {
    const std::string_view part = parts[i];
    const std::size_t eq = part.find('=');
    if (eq == std::string_view::npos) {
      if (i != 1) return bad("the seed comes right after NAME, before the options");
      const char* end = part.data() + part.size();
      const auto [used, ec] = std::from_chars(part.data(), end, scene.seed);
      if (part.empty() || ec != std::errc() || used != end) {
        return bad("the seed must be an integer in [0, 4294967295]");
      }
      continue;
    }
    const std::string_view key = part.substr(0, eq), value = part.substr(eq + 1);
    std::optional<double>* slot = key == "size_m"      ? &scene.options.size_m
                                  : key == "spacing_m" ? &scene.options.spacing_m
                                                       : nullptr;
    if (slot == nullptr) {
      return bad("unknown option '" + std::string(key) + "': the options are size_m and spacing_m");
    }
    if (slot->has_value()) return bad(std::string(key) + " is given twice");
    double number = 0;
    const char* end = value.data() + value.size();
    const auto [used, ec] = std::from_chars(value.data(), end, number);
    if (value.empty() || ec != std::errc() || used != end || !std::isfinite(number)) {
      return bad(std::string(key) + " must be a decimal number in metres, e.g. " +
                 std::string(key) + (key == "size_m" ? "=400" : "=0.2"));
    }
    *slot = number;
  }
  return scene;
}

std::string FormatSceneSource(const SceneSource& scene) {
  std::string text = std::string(kScenePrefix) + scene.name + ":" + std::to_string(scene.seed);
  const auto option = [&text](const char* key, const std::optional<double>& value) {
    if (!value) return;
    char digits[32];
    const auto [end, ec] = std::to_chars(digits, digits + sizeof digits, *value);
    text.append(":").append(key).append("=").append(digits, ec == std::errc() ? end : digits);
  };
  option("size_m", scene.options.size_m);
  option("spacing_m", scene.options.spacing_m);
  return text;
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
  Expected<PointCloud> cloud =
      GenerateScene(scene.name, scene.seed, scene.options, limits.max_points);
  if (!cloud) return cloud.error();
  return SanitizeCloud(std::move(cloud).value(), limits);
}

}  // namespace strata
