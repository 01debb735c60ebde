#pragma once
/// outdoor_site: a large outdoor site whose side is a parameter, for site-scale tests and
/// benchmarks without downloads. Conventions as in strata/scenes/scenes.hpp (lattice at about
/// `spacing_m` with seeded jitter, visible faces only, the same cloud for the same seed, size
/// and spacing on every platform); docs/scenes.md describes it.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "strata/point_cloud.hpp"
#include "strata/scenes/paper_scenes.hpp"

namespace strata {

/// Side of the site when none is given [m].
inline constexpr double kOutdoorSiteDefaultSizeM = 100.0;
/// Sides GenerateOutdoorSite accepts [m]: the compound (bridge and building) needs 40 m.
inline constexpr double kOutdoorSiteMinSizeM = 40.0;
inline constexpr double kOutdoorSiteMaxSizeM = 1000.0;

/// A square site x, y in [0, size_m] (size_m in [40, 1000] m):
/// - rolling hills, laid out by the seed, whose relief (highest minus lowest ground) is
///   0.03 × size_m (3 m at 100 m, 12 m at 400 m, 30 m at 1 km) unless that would make them
///   steeper than 12°, which they never are (the relief is then smaller); the same landscape
///   scaled with the site, so slopes do not grow with it. Around the compound the hills
///   flatten into a level pad at z = 0, which takes most of the smallest sites;
/// - steep heaps (flanks of 29.6–35.8°, radius 8–12 m), about one per 140 m × 140 m where they
///   fit (none at 40 m), off the pad and away from the query ends;
/// - box obstacles: ISO 20 ft containers (one in five stacked two high), sheds and free
///   walls, about 1,500 per km² (one per 16 m × 16 m cell at most), at least 3 m apart, off
///   the pad, the heaps and the query ends;
/// - at the centre, on the pad, a compound 40 m × 30 m: a bridge (deck 5 m wide, top at
///   2.8 m, 2.5 m clear underneath) over a road, reached by a 12° solid ramp at each end, with
///   1 m railings; and a two-storey building 26 m × 14 m (upper floor at 3 m, flat roof at
///   6 m) whose upper floor is reached by a 12° ramp inside it through an opening in that
///   floor, with two doors on the ground floor and a partition with a door upstairs.
/// Points lie in x, y in [0, size_m] (widened by the jitter), z within the relief plus 6 m.
/// The ground gives (size_m / spacing_m + 1)² points less what footprints hide; obstacles and
/// the compound add about 8% at 1 km and 27% at 100 m: 1.28 M points at the defaults
/// (100 m, 0.1 m), 17.4 M at 400 m and 0.1 m, 27 M at 1 km and 0.2 m. The cloud is reserved
/// for an upper bound counted before sampling (about 3% above), so it is never reallocated.
/// An empty cloud for a size outside [40, 1000] m or an invalid spacing.
/// Coordinates: GetOutdoorSiteLayout(seed, size_m).
PointCloud GenerateOutdoorSite(std::uint32_t seed, double size_m = kOutdoorSiteDefaultSizeM,
                               double spacing_m = 0.1);

/// What GenerateOutdoorSite builds for one seed and size (independent of the spacing) [m].
struct OutdoorSiteLayout {
  /// One scale of the hills: a uniform bicubic B-spline over [0, size]², `cells` knot
  /// intervals per side, coefficients row-major ((cells + 3)² of them, x outer).
  struct Octave {
    double knot_spacing_m;
    int cells;
    std::vector<double> coefficients;  ///< Unscaled, in [-1, 1] before the flattening.
  };
  /// A heap: adds height_m · (1 - d²/radius²)³ at distance d < radius from its centre;
  /// steepest flank atan(1.717 · height / radius).
  struct Heap {
    double x_m, y_m, radius_m, height_m;
  };
  /// An axis-aligned box standing on the ground: [lo, hi], lo.z below the lowest ground
  /// under it, hi.z the highest ground under its corners plus its height.
  struct Obstacle {
    enum class Kind { kContainer, kShed, kWall };
    Kind kind;
    Eigen::Vector3d lo_m, hi_m;
  };
  /// An opening in a wall: along the wall from `from_m` to `to_m` (x for a wall along x, y
  /// otherwise), from its floor to `top_z_m`.
  struct Door {
    double from_m, to_m, floor_z_m, top_z_m;
  };

  double size_m;  ///< The site is [0, size] × [0, size].

  /// Ground height at (x, y) [m]: hills, pad and heaps (not obstacles or structures).
  double GroundZAt(double x_m, double y_m) const;
  /// Whether (x, y) lies on the level pad.
  bool OnPad(double x_m, double y_m) const;
  /// Whether the upper floor has floor over (x, y): inside the building, not in the opening.
  bool HasUpperFloor(double x_m, double y_m) const;

  // Hills: GroundZAt = hill_scale · (1 - w) · (octaves' sum - hill_offset) + heaps, where the
  // weight w falls smoothly from 1 on the pad to 0 at blend_m from it.
  std::vector<Octave> octaves;  ///< Coarse first.
  double hill_scale;            ///< Metres per unit of the octaves' sum.
  double hill_offset;           ///< The octaves' sum at the pad's centre.
  double relief_m;              ///< Highest minus lowest ground without the heaps.
  double pad_x_min_m, pad_x_max_m, pad_y_min_m, pad_y_max_m;  ///< Level ground at z = 0 ...
  double blend_m;  ///< ... joining the hills over this distance around it.
  std::vector<Heap> heaps;
  std::vector<Obstacle> obstacles;

  // The compound.
  double compound_x_min_m, compound_y_min_m;        ///< South-west corner; 40 m × 30 m.
  double railing_height_m;                          ///< Railings above their floor.
  double bridge_deck_z_m;                           ///< Deck top.
  double bridge_deck_underside_z_m;                 ///< Deck slab's lower face.
  double bridge_span_x_min_m, bridge_span_x_max_m;  ///< Elevated part between the ramps ...
  double bridge_y_min_m, bridge_y_max_m;            ///< ... and its width (ramps as well).
  std::vector<SceneRamp> bridge_ramps;              ///< West (+x), east (-x).
  double road_x_min_m, road_x_max_m;  ///< The road under the span, from the compound's south
  double road_y_min_m, road_y_max_m;  ///< edge to the building.
  double building_x_min_m, building_x_max_m, building_y_min_m, building_y_max_m;
  double ground_floor_z_m;           ///< 0, the pad.
  double upper_floor_z_m;            ///< Upper floor's top.
  double upper_floor_underside_z_m;  ///< Its lower face (the ground floor's ceiling).
  double roof_z_m;                   ///< Roof top; the outer walls reach it.
  double roof_underside_z_m;         ///< The upper storey's ceiling.
  SceneRamp building_ramp;           ///< Ground floor to upper floor, through an opening in it.
  Door west_door;                    ///< Ground floor, in the wall x = building_x_min.
  Door south_door;                   ///< Ground floor, in the wall y = building_y_min.
  double partition_x_m;              ///< Upper-storey partition across the building ...
  Door partition_door;               ///< ... and its door.

  double assessment_resolution_m = 0.2;  ///< Grid resolution the queries are checked at.
  /// across_the_hills (south-west to north-east corner), ground_to_bridge_deck,
  /// under_the_bridge (along the road), ground_to_upper_floor (in through the west door,
  /// up the ramp, through the partition's door); differential robot.
  std::vector<SceneQuery> queries;
};

/// The layout for `seed` and `size_m` (clamped to [40, 1000] m).
OutdoorSiteLayout GetOutdoorSiteLayout(std::uint32_t seed,
                                       double size_m = kOutdoorSiteDefaultSizeM);

}  // namespace strata
