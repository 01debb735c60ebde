// The scenes by name: one table of names, default spacings and generators.
#include "strata/scenes/scenes.hpp"

#include <cstdio>
#include <string>

#include "scenes_internal.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/paper_scenes.hpp"

namespace strata {

using internal::IsValidSpacing;

namespace {

// One row per scene: name, default spacing and generator.
struct SceneEntry {
  const char* name;
  double default_spacing_m;
  PointCloud (*generate)(std::uint32_t seed, double spacing_m);
};

constexpr SceneEntry kScenes[] = {
    {"stairs_ramp_room", 0.05, &GenerateStairsRampRoom},
    {"two_level_ramp", 0.1, &GenerateTwoLevelRamp},
    {"uneven_terrain", 0.1, &GenerateUnevenTerrain},
    {"uneven_forest", 0.1, &GenerateUnevenForest},
    {"abandoned_station", 0.1, &GenerateAbandonedStation},
    {"parking_garage", 0.16, &GenerateParkingGarage},
    {"crossing_viaducts", 0.16, &GenerateCrossingViaducts},
    {"indoor_tables", 0.05, &GenerateIndoorTables},
};

Expected<const SceneEntry*> FindScene(const std::string& name) {
  for (const SceneEntry& entry : kScenes) {
    if (name == entry.name) return &entry;
  }
  std::string known;
  for (const std::string& n : SceneNames()) known += (known.empty() ? "" : ", ") + n;
  return Error{ErrorCode::kInvalidInput, "unknown scene \"" + name + "\"; known scenes: " + known};
}

}  // namespace

std::vector<std::string> SceneNames() {
  std::vector<std::string> names;
  for (const SceneEntry& entry : kScenes) names.emplace_back(entry.name);
  return names;
}

Expected<double> DefaultSceneSpacing(const std::string& name) {
  Expected<const SceneEntry*> entry = FindScene(name);
  if (!entry) return entry.error();
  return (*entry)->default_spacing_m;
}

Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed) {
  Expected<const SceneEntry*> entry = FindScene(name);
  if (!entry) return entry.error();
  return (*entry)->generate(seed, (*entry)->default_spacing_m);
}

Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed, double spacing_m) {
  Expected<const SceneEntry*> entry = FindScene(name);
  if (!entry) return entry.error();
  if (!IsValidSpacing(spacing_m)) {
    char value[32];
    std::snprintf(value, sizeof(value), "%g", spacing_m);
    return Error{ErrorCode::kInvalidInput, std::string("scene spacing_m = ") + value +
                                               " is out of range: must be finite and >= 0.01 m"};
  }
  return (*entry)->generate(seed, spacing_m);
}

}  // namespace strata
