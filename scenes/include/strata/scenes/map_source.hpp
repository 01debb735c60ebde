#pragma once
/// Where a map's points come from: a point-cloud file or a built-in scene, written
/// "scene:NAME[:SEED][:size_m=M][:spacing_m=M]". One parser and one loader, used by
/// strata-server's map registry and its --preload, by strata-offline and by strata-bench, so
/// that a scene with the same name, seed and options is the same map in all of them.

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include "strata/io/cloud_io.hpp"
#include "strata/scenes/scenes.hpp"
#include "strata/status.hpp"

namespace strata {

/// The seed of a scene given without one ("scene:NAME", a CreateMap request whose SceneSource
/// has no seed). 1, the seed the figures in docs/benchmarks.md and docs/scenes.md were
/// measured with.
inline constexpr std::uint32_t kDefaultSceneSeed = 1;

/// What marks a map source as a scene: "scene:NAME[:SEED][:size_m=M][:spacing_m=M]".
inline constexpr std::string_view kScenePrefix = "scene:";

/// A built-in scene: GenerateScene(name, seed, options).
struct SceneSource {
  std::string name;                        ///< One of SceneNames().
  std::uint32_t seed = kDefaultSceneSeed;  ///< Seed of the jitter (and of some layouts).
  SceneOptions options;                    ///< Size and spacing; unset: the scene's defaults.
};

/// A point-cloud file in a format LoadPointCloud reads (.pcd, .ply, .bt, .ot).
struct FileSource {
  std::string path;
};

using MapSource = std::variant<FileSource, SceneSource>;

/// Parses "scene:NAME[:SEED][:size_m=M][:spacing_m=M]": NAME non-empty; SEED, right after it,
/// an unsigned 32-bit decimal integer (kDefaultSceneSeed when absent); then each option at
/// most once, in any order, its value a finite decimal number in metres
/// ("scene:outdoor_site:size_m=400:spacing_m=0.2"). kInvalidInput naming the text and the
/// problem otherwise. Whether NAME is a known scene and the values are in range is left to
/// GenerateScene (and LoadMapSource), which names the known scenes and the ranges.
Expected<SceneSource> ParseSceneSource(std::string_view text);

/// The text ParseSceneSource reads back as `scene`: "scene:NAME:SEED" and each option set,
/// numbers in their shortest form that reads back exactly.
std::string FormatSceneSource(const SceneSource& scene);

/// A scene when `text` starts with kScenePrefix (ParseSceneSource), a file path otherwise.
Expected<MapSource> ParseMapSource(std::string_view text);

/// Reads the file (LoadPointCloud) or generates the scene (GenerateScene, which refuses a
/// scene estimated above limits.max_points before generating it) and sanitises it
/// (SanitizeCloud), within `limits`. Fails as they do.
Expected<LoadedCloud> LoadMapSource(const MapSource& source, const CloudLoadLimits& limits = {});

}  // namespace strata
