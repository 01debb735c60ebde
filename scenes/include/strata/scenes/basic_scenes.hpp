#pragma once
/// Three small scenes for tests and demos: a room with stairs, a ramp and a low shelf; a hall
/// on two levels joined by a ramp (the server's demo map); rolling terrain with trees and
/// rocks. Conventions (lattice, jitter, determinism, spacing) as in strata/scenes/scenes.hpp.
/// Each comes with a Layout of its key coordinates, so tests query regions without magic
/// numbers.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "strata/point_cloud.hpp"

namespace strata {

/// A room x in [0, 8] m, y in [0, 7] m with a flat floor at z = 0 and walls 2 m high. At the
/// far end (y = 6..7 m) a solid landing deck at z = 0.9 m spans the room; side by side below
/// it, a flight of stairs (6 risers of 0.15 m, treads 0.25 m, 1.2 m wide) and a straight ramp
/// of slope 10° (1.5 m wide, 1.2 m apart from the stairs in x), both rising along +y to the
/// landing. Stairs and ramp are solids: treads, risers and side faces are sampled. A low shelf
/// (1.2 × 0.8 m slab, underside 0.25 m, top 0.30 m, on four thin legs) stands over open floor.
/// Points lie in the room box (widened by the jitter), z in [0, 2] m. At the default spacing
/// 0.05 m: about 51k points (13k at 0.1 m). The seed only changes the jitter. The room is 7 m
/// deep rather than 6 m because the 10° ramp alone needs a 5.1 m run to climb 0.9 m.
/// Coordinates: StairsRampLayout.
PointCloud GenerateStairsRampRoom(std::uint32_t seed, double spacing_m = 0.05);

/// Key coordinates of GenerateStairsRampRoom [m, rad], so tests can query regions without
/// magic numbers. The generator builds the scene from this very layout.
struct StairsRampLayout {
  double room_x_max_m, room_y_max_m;      ///< The room is [0, room_x_max] × [0, room_y_max].
  double wall_height_m;                   ///< Walls run from z = 0 to this height.
  double stairs_x_min_m, stairs_x_max_m;  ///< Stairs occupy x in this range ...
  double stairs_y_min_m, stairs_y_max_m;  ///< ... and y in this range (rising with y).
  double riser_m, tread_m;                ///< Step height and step depth.
  int stair_risers;                       ///< Risers; the last one ends at the landing.
  double ramp_x_min_m, ramp_x_max_m;      ///< Ramp occupies x in this range ...
  double ramp_y_min_m, ramp_y_max_m;      ///< ... and y in this range (rising with y).
  double ramp_slope_rad;                  ///< Ramp inclination; its toe is at z = 0.
  double landing_z_m;                     ///< Height of the landing the stairs and ramp reach.
  double landing_y_min_m;                 ///< Landing front edge; the landing reaches the far wall.
  double shelf_x_min_m, shelf_x_max_m, shelf_y_min_m, shelf_y_max_m;  ///< Shelf footprint.
  double shelf_underside_z_m;  ///< Height of the shelf slab's lower face.
  double shelf_top_z_m;        ///< Height of the shelf slab's upper face.
};
StairsRampLayout GetStairsRampLayout();

/// Two levels in a hall x in [0, 20] m, y in [0, 12] m with outer walls 4 m high: a ground
/// floor at z = 0 and an upper deck slab (top z = 3 m, underside 2.8 m, both faces sampled)
/// over 55% of it: the strip y >= 6.5 m plus a tongue x >= 16.5 m. A straight 12° ramp
/// (2.5 m wide, y in [1.5, 4] m) rises along +x from the floor to the tongue's edge; it is a
/// solid wedge (top, sides and back face sampled). Five pillars (radius 0.3 m) hold the deck; a
/// 1 m railing (a thin sampled sheet) runs along the deck's open edges except where the ramp
/// arrives. Points lie in the hall box (widened by the jitter), z in [0, 4] m. At the default
/// spacing 0.1 m: about 88k points. The seed only changes the jitter. Coordinates:
/// TwoLevelRampLayout.
PointCloud GenerateTwoLevelRamp(std::uint32_t seed, double spacing_m = 0.1);

/// Key coordinates of GenerateTwoLevelRamp [m, rad]; the generator builds the scene from it.
struct TwoLevelRampLayout {
  double room_x_max_m, room_y_max_m;  ///< The hall is [0, room_x_max] × [0, room_y_max].
  double wall_height_m;               ///< Outer walls run from z = 0 to this height.
  double floor_z_m;                   ///< Ground floor height.
  double deck_z_m;                    ///< Height of the deck's walkable top face.
  double deck_underside_z_m;          ///< Height of the deck slab's lower face.
  double deck_y_min_m;                ///< The deck covers y >= deck_y_min (whole width) ...
  double deck_tongue_x_min_m;         ///< ... and x >= deck_tongue_x_min (whole depth).
  double ramp_x_min_m, ramp_x_max_m;  ///< Ramp footprint in x (toe at x_min, top at x_max) ...
  double ramp_y_min_m, ramp_y_max_m;  ///< ... and in y.
  double ramp_slope_rad;              ///< Ramp inclination.
  Eigen::Vector2d ramp_uphill_dir;    ///< Unit horizontal direction the ramp rises along.
  double railing_height_m;            ///< Railing height above the deck top.
  double pillar_radius_m;             ///< Radius of every pillar.
  std::vector<Eigen::Vector2d> pillar_centers_m;  ///< Pillar axes; each spans floor to deck.
  Eigen::Vector3d start_example_m;  ///< A point on the open ground floor, clear of obstacles.
  Eigen::Vector3d goal_example_m;   ///< A point on the deck top, reached via the ramp.

  /// Whether the deck lies over (x, y) [m] (footprint edges included).
  bool IsOverDeck(double x_m, double y_m) const;
};
TwoLevelRampLayout GetTwoLevelRampLayout();

/// Rolling terrain x, y in [0, 30] m: a height field made of a few seeded Gaussian hills and
/// hollows (one of them always steep, so slopes range from flat to beyond 30°) plus a gentle
/// sinusoid; 15–25 trees (trunk radius 0.15–0.3 m, crown a sphere of radius 1–2 m centred at
/// 3.2–5 m above the trunk's foot, crown bottom >= 2.2 m above it) and 10–15 partly buried
/// ellipsoidal rocks (horizontal radius 0.3–0.8 m), all placed by the seed on slopes under 20°
/// (trees) or 25° (rocks). The seed changes the whole scene. Points lie in x, y in [0, 30] m
/// (widened by the jitter), z roughly in [-4, 14] m. At the default spacing 0.1 m: 135k–165k
/// points. Coordinates: GetUnevenTerrainLayout(seed).
PointCloud GenerateUnevenTerrain(std::uint32_t seed, double spacing_m = 0.1);

/// What GenerateUnevenTerrain places for one seed (independent of the spacing) [m].
struct UnevenTerrainLayout {
  /// Adds height_m · exp(-|(x, y) - (x_m, y_m)|² / (2 sigma_m²)) to the terrain; a hollow
  /// when height_m < 0.
  struct Hill {
    double x_m, y_m;  ///< Centre.
    double height_m;  ///< Peak height (negative: depth of a hollow).
    double sigma_m;   ///< Width (standard deviation), > 0.
  };
  /// A trunk rising from below the ground into a spherical crown.
  struct Tree {
    double x_m, y_m;          ///< Trunk axis.
    double ground_z_m;        ///< Terrain height at the trunk axis.
    double trunk_radius_m;    ///< In [0.15, 0.3].
    double crown_center_z_m;  ///< Crown sphere centre, on the trunk axis; 3.2–5 m above ground.
    double crown_radius_m;    ///< In [1, 2]; the crown bottom is >= 2.2 m above ground_z_m.
  };
  /// An ellipsoid, round in plan, partly buried: its centre is below the ground.
  struct Rock {
    double x_m, y_m;     ///< Centre in plan.
    double center_z_m;   ///< Centre height, 20% of radius_z_m below the terrain.
    double radius_xy_m;  ///< Horizontal radius, in [0.3, 0.8].
    double radius_z_m;   ///< Vertical radius, 0.6–1 times radius_xy_m.
  };

  double size_m;            ///< The terrain covers [0, size] × [0, size].
  std::vector<Hill> hills;  ///< The first one is the steep hill (slopes beyond 30°).
  double wave_amplitude_m;  ///< Adds A·sin(2πx/L + φx)·sin(2πy/L + φy): A ...
  double wave_length_m;     ///< ... L ...
  double wave_phase_x_rad;  ///< ... φx ...
  double wave_phase_y_rad;  ///< ... and φy.
  std::vector<Tree> trees;  ///< 15–25 trees, on slopes under 20°, crowns apart.
  std::vector<Rock> rocks;  ///< 10–15 rocks, on slopes under 25°, clear of trunks.

  /// Terrain height [m] at (x, y) [m] (bare ground, without trees or rocks).
  double HeightAt(double x_m, double y_m) const;
  /// Gradient of HeightAt [-]; the slope angle is atan(|gradient|).
  Eigen::Vector2d GradientAt(double x_m, double y_m) const;
};
UnevenTerrainLayout GetUnevenTerrainLayout(std::uint32_t seed);

}  // namespace strata
