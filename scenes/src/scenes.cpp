// The scenes by name: one table of names, default parameters, generators and point estimates.
#include "strata/scenes/scenes.hpp"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "scenes_internal.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/outdoor_site.hpp"
#include "strata/scenes/paper_scenes.hpp"

namespace strata {

using internal::IsValidSpacing;

namespace {

// A scene's size parameter: default and range [m], and an upper bound of its points at a size
// and spacing.
struct SizeParameter {
  double default_m, min_m, max_m;
  std::size_t (*point_bound)(std::uint32_t seed, double size_m, double spacing_m);
};

// One row per scene: name, default spacing, generator (the size is ignored by scenes without a
// size parameter), and what its point count follows: without a size parameter the area of its
// sampled surfaces [m²] (points ≈ area / spacing², measured at a quarter of the default
// spacing; for uneven_terrain and uneven_forest the middle of their seeds' range), with one
// the size's point bound.
struct SceneEntry {
  const char* name;
  double default_spacing_m;
  PointCloud (*generate)(std::uint32_t seed, double size_m, double spacing_m);
  double sampled_area_m2;
  const SizeParameter* size = nullptr;
};

template <PointCloud (*Generate)(std::uint32_t, double)>
PointCloud WithoutSize(std::uint32_t seed, double /*size_m*/, double spacing_m) {
  return Generate(seed, spacing_m);
}

constexpr SizeParameter kOutdoorSiteSize{kOutdoorSiteDefaultSizeM, kOutdoorSiteMinSizeM,
                                         kOutdoorSiteMaxSizeM, &internal::OutdoorSitePointBound};

constexpr SceneEntry kScenes[] = {
    {"stairs_ramp_room", 0.05, &WithoutSize<&GenerateStairsRampRoom>, 125.0},
    {"two_level_ramp", 0.1, &WithoutSize<&GenerateTwoLevelRamp>, 865.0},
    {"uneven_terrain", 0.1, &WithoutSize<&GenerateUnevenTerrain>, 1500.0},
    {"uneven_forest", 0.1, &WithoutSize<&GenerateUnevenForest>, 2750.0},
    {"abandoned_station", 0.1, &WithoutSize<&GenerateAbandonedStation>, 2650.0},
    {"parking_garage", 0.16, &WithoutSize<&GenerateParkingGarage>, 9600.0},
    {"crossing_viaducts", 0.16, &WithoutSize<&GenerateCrossingViaducts>, 9650.0},
    {"indoor_tables", 0.05, &WithoutSize<&GenerateIndoorTables>, 240.0},
    {"outdoor_site", 0.1, &GenerateOutdoorSite, 0.0, &kOutdoorSiteSize},
};

std::string JoinedNames(bool (*select)(const SceneEntry&)) {
  std::string names;
  for (const SceneEntry& entry : kScenes) {
    if (select(entry)) names += (names.empty() ? "" : ", ") + std::string(entry.name);
  }
  return names;
}

Expected<const SceneEntry*> FindScene(const std::string& name) {
  for (const SceneEntry& entry : kScenes) {
    if (name == entry.name) return &entry;
  }
  return Error{ErrorCode::kInvalidInput, "unknown scene \"" + name + "\"; known scenes: " +
                                             JoinedNames([](const SceneEntry&) { return true; })};
}

// The entry and its options, every one it has set.
struct ResolvedScene {
  const SceneEntry* entry;
  SceneOptions options;
};

Expected<ResolvedScene> Resolve(const std::string& name, const SceneOptions& options) {
  Expected<const SceneEntry*> found = FindScene(name);
  if (!found) return found.error();
  const SceneEntry& entry = **found;
  ResolvedScene resolved{&entry, options};
  if (entry.size == nullptr && options.size_m) {
    return Error{ErrorCode::kInvalidInput,
                 "scene " + name + " has no size parameter: leave size_m unset (only " +
                     JoinedNames([](const SceneEntry& e) { return e.size != nullptr; }) +
                     " take one)"};
  }
  if (entry.size != nullptr) {
    const double size = options.size_m.value_or(entry.size->default_m);
    if (!(size >= entry.size->min_m && size <= entry.size->max_m)) {
      return Error{ErrorCode::kInvalidInput,
                   fmt::format("scene {}: size_m = {:g} is out of range: must be in [{:g}, {:g}] m",
                               name, size, entry.size->min_m, entry.size->max_m)};
    }
    resolved.options.size_m = size;
  }
  const double spacing = options.spacing_m.value_or(entry.default_spacing_m);
  if (!IsValidSpacing(spacing)) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("scene {}: spacing_m = {:g} is out of range: must be finite and "
                             ">= {:g} m",
                             name, spacing, internal::kMinSpacingM)};
  }
  resolved.options.spacing_m = spacing;
  return resolved;
}

double Estimate(const ResolvedScene& scene, std::uint32_t seed) {
  const double spacing = *scene.options.spacing_m;
  if (scene.entry->size != nullptr) {
    return static_cast<double>(
        scene.entry->size->point_bound(seed, *scene.options.size_m, spacing));
  }
  return scene.entry->sampled_area_m2 / (spacing * spacing);
}

Status CheckPoints(const ResolvedScene& scene, std::uint32_t seed, std::size_t max_points) {
  const double points = Estimate(scene, seed);
  if (points <= static_cast<double>(max_points)) return Status::Ok();
  const SceneOptions& o = scene.options;
  // Points fall with the square of the spacing; name the next centimetre that fits.
  const double fits = std::ceil(100.0 * *o.spacing_m * std::sqrt(points / max_points)) / 100.0;
  const std::string size = o.size_m ? fmt::format("size_m = {:g}, ", *o.size_m) : "";
  return Error{ErrorCode::kResourceExhausted,
               fmt::format("scene {} ({}spacing_m = {:g}) would have about {:g} points, above "
                           "the limit of {}: use spacing_m >= {:g}{}",
                           scene.entry->name, size, *o.spacing_m, points, max_points, fits,
                           o.size_m ? " or a smaller size_m" : "")};
}

}  // namespace

std::vector<std::string> SceneNames() {
  std::vector<std::string> names;
  for (const SceneEntry& entry : kScenes) names.emplace_back(entry.name);
  return names;
}

Expected<SceneOptions> ResolveSceneOptions(const std::string& name, const SceneOptions& options) {
  Expected<ResolvedScene> resolved = Resolve(name, options);
  if (!resolved) return resolved.error();
  return resolved->options;
}

Expected<double> EstimateScenePoints(const std::string& name, std::uint32_t seed,
                                     const SceneOptions& options) {
  Expected<ResolvedScene> resolved = Resolve(name, options);
  if (!resolved) return resolved.error();
  return Estimate(*resolved, seed);
}

Status CheckScene(const std::string& name, std::uint32_t seed, const SceneOptions& options,
                  std::size_t max_points) {
  Expected<ResolvedScene> resolved = Resolve(name, options);
  if (!resolved) return resolved.error();
  return CheckPoints(*resolved, seed, max_points);
}

Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed,
                                   const SceneOptions& options, std::size_t max_points) {
  Expected<ResolvedScene> resolved = Resolve(name, options);
  if (!resolved) return resolved.error();
  if (Status fits = CheckPoints(*resolved, seed, max_points); !fits) return fits.error();
  const SceneOptions& o = resolved->options;
  return resolved->entry->generate(seed, o.size_m.value_or(0.0), *o.spacing_m);
}

}  // namespace strata
