#pragma once
/// Deterministic synthetic scenes (by seed) for tests, demos and benchmarks, by name. The
/// scenes themselves and their layouts: strata/scenes/basic_scenes.hpp,
/// strata/scenes/paper_scenes.hpp and strata/scenes/outdoor_site.hpp; docs/scenes.md describes
/// each.
///
/// Surfaces are sampled as points on a regular lattice at about `spacing_m` (the lattice is
/// fitted to each surface's edges) with seeded jitter of at most 10% of the spacing across the
/// lattice and at most min(5 mm, 10% of the spacing) in z, like a dense lidar map. Faces a
/// sensor could not see (the floor under a ramp, a wall behind a solid landing) are not sampled.
///
/// The same seed, size and spacing give the identical cloud on every platform: only
/// std::mt19937 and std::seed_seq are used, never the std distributions (their output is
/// implementation-defined). `spacing_m` must be finite and >= 0.01 m; otherwise the generators
/// return an empty cloud.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "strata/io/cloud_io.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

/// A scene's parameters beyond its name and seed; unset ones take the scene's defaults
/// (ResolveSceneOptions fills them in).
struct SceneOptions {
  /// Side of the scene [m], only for a scene with a size parameter: outdoor_site, in
  /// [40, 1000], default 100.
  std::optional<double> size_m;
  /// Lattice spacing of the sampled surfaces [m], finite and >= 0.01; default: the scene's
  /// own (docs/scenes.md lists them).
  std::optional<double> spacing_m;
};

/// Names accepted by GenerateScene: "stairs_ramp_room", "two_level_ramp", "uneven_terrain"
/// (basic_scenes.hpp), "uneven_forest", "abandoned_station", "parking_garage",
/// "crossing_viaducts", "indoor_tables" (paper_scenes.hpp) and "outdoor_site"
/// (outdoor_site.hpp).
std::vector<std::string> SceneNames();

/// `options` with every parameter the scene has set, to its default where unset: the spacing
/// always, the size only for a scene with a size parameter. kInvalidInput naming the known
/// scenes for an unknown name, naming the scenes that take a size for a size given to another
/// scene, and naming the value and its range for a size or a spacing out of range.
Expected<SceneOptions> ResolveSceneOptions(const std::string& name, const SceneOptions& options);

/// About how many points GenerateScene gives [-], without generating: the area of the scene's
/// sampled surfaces over the spacing squared (within 10% at the default spacing or finer);
/// for outdoor_site an upper bound, every lattice point counted (about 5% above). Fails like
/// ResolveSceneOptions.
Expected<double> EstimateScenePoints(const std::string& name, std::uint32_t seed,
                                     const SceneOptions& options = {});

/// What GenerateScene checks before it generates anything: the name and the options (failing
/// like ResolveSceneOptions), and EstimateScenePoints against `max_points` (kResourceExhausted
/// naming the spacing that fits).
Status CheckScene(const std::string& name, std::uint32_t seed, const SceneOptions& options,
                  std::size_t max_points = CloudLoadLimits{}.max_points);

/// The named scene, once CheckScene passes (its error otherwise).
Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed,
                                   const SceneOptions& options = {},
                                   std::size_t max_points = CloudLoadLimits{}.max_points);

}  // namespace strata
