#pragma once
/// Deterministic synthetic scenes (by seed) for tests, demos and benchmarks, by name. The
/// scenes themselves and their layouts: strata/scenes/basic_scenes.hpp and
/// strata/scenes/paper_scenes.hpp; docs/scenes.md describes each.
///
/// Surfaces are sampled as points on a regular lattice at about `spacing_m` (the lattice is
/// fitted to each surface's edges) with seeded jitter of at most 10% of the spacing across the
/// lattice and at most min(5 mm, 10% of the spacing) in z, like a dense lidar map. Faces a
/// sensor could not see (the floor under a ramp, a wall behind a solid landing) are not sampled.
///
/// The same seed and spacing give the identical cloud on every platform: only std::mt19937 and
/// std::seed_seq are used, never the std distributions (their output is implementation-defined).
/// `spacing_m` must be finite and >= 0.01 m; otherwise the generators return an empty cloud.

#include <cstdint>
#include <string>
#include <vector>

#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

/// Names accepted by GenerateScene: "stairs_ramp_room", "two_level_ramp", "uneven_terrain"
/// (basic_scenes.hpp) and "uneven_forest", "abandoned_station", "parking_garage",
/// "crossing_viaducts", "indoor_tables" (paper_scenes.hpp).
std::vector<std::string> SceneNames();

/// The default spacing of the named scene [m]; kInvalidInput naming the known scenes otherwise.
Expected<double> DefaultSceneSpacing(const std::string& name);

/// The named scene at its default spacing; kInvalidInput naming the known scenes otherwise.
Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed);

/// The named scene at `spacing_m`; kInvalidInput naming the known scenes for an unknown name,
/// or naming the value for a spacing that is not finite or below 0.01 m.
Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed, double spacing_m);

}  // namespace strata
