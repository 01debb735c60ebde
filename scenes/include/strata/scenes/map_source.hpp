#pragma once
/// Where a map's points come from: a point-cloud file or a built-in scene, written
/// "scene:NAME[:SEED]". One parser and one loader, used by strata-server's map registry and by
/// strata-offline, so that a scene with the same name and seed is the same map in both.

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include "strata/cloud_io.hpp"
#include "strata/status.hpp"

namespace strata {

/// The seed of a scene given without one ("scene:NAME", a CreateMap request whose SceneSource
/// has no seed). 1, the seed the figures in docs/benchmarks.md and docs/scenes.md were
/// measured with.
inline constexpr std::uint32_t kDefaultSceneSeed = 1;

/// What marks a map source as a scene: "scene:NAME[:SEED]".
inline constexpr std::string_view kScenePrefix = "scene:";

/// A built-in scene (GenerateScene at the scene's default spacing).
struct SceneSource {
  std::string name;                        ///< One of SceneNames().
  std::uint32_t seed = kDefaultSceneSeed;  ///< Seed of the jitter (and of some layouts).
};

/// A point-cloud file in a format LoadPointCloud reads (.pcd, .ply, .bt, .ot).
struct FileSource {
  std::string path;
};

using MapSource = std::variant<FileSource, SceneSource>;

/// Parses "scene:NAME[:SEED]": NAME non-empty, SEED an unsigned 32-bit decimal integer
/// (kDefaultSceneSeed when absent). kInvalidInput naming the text otherwise. Whether NAME is a
/// known scene is left to GenerateScene (and LoadMapSource), which lists the known ones.
Expected<SceneSource> ParseSceneSource(std::string_view text);

/// A scene when `text` starts with kScenePrefix (ParseSceneSource), a file path otherwise.
Expected<MapSource> ParseMapSource(std::string_view text);

/// Reads the file (LoadPointCloud) or generates the scene and sanitises it (GenerateScene, then
/// SanitizeCloud), within `limits`. Fails as they do.
Expected<LoadedCloud> LoadMapSource(const MapSource& source, const CloudLoadLimits& limits = {});

}  // namespace strata
