#pragma once
/// Five scenes modelled on the paper's experiments (Sec. VI: an uneven forest, an abandoned
/// station, a multi-level parking garage, crossing viaducts, and an indoor room with tables for
/// the wheeled biped); the comparison harness (bench/compare/) runs on them. Same conventions
/// as strata/scenes/scenes.hpp: surfaces sampled on a lattice at about
/// `spacing_m` with seeded jitter (at most 10% of the spacing across, min(5 mm, 10%) in z),
/// solids sampled on their visible faces only, identical output for the same seed and spacing
/// on every platform, an empty cloud for a spacing that is not finite or below 0.01 m. Only
/// uneven_forest is laid out by the seed; in the others the seed changes the jitter only.
///
/// Each scene comes with a Layout: its bounds, levels and key coordinates, and a few example
/// queries (SceneQuery) that plan successfully at the documented assessment resolution (the
/// tests check them). Elevated edges carry 1 m railings (thin sampled sheets) except where a
/// ramp arrives; ramps are at most 12° and at least 3 m wide. Counts below are at the default
/// spacing. Assess at a grid resolution of at least 1.25 × the spacing (each layout names
/// one): on a finer grid some columns receive no lattice point and the ground gets holes.
/// docs/scenes.md describes what makes each scene hard.

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "strata/point_cloud.hpp"
#include "strata/scenes/basic_scenes.hpp"

namespace strata {

/// A straight ramp over an axis-aligned footprint, rising from z_low_m at its toe to z_high_m
/// at its top edge along uphill_dir (±x or ±y) [m].
struct SceneRamp {
  double x_min_m = 0, x_max_m = 0, y_min_m = 0, y_max_m = 0;  ///< Footprint.
  double z_low_m = 0;   ///< Height of the toe (the floor it starts from).
  double z_high_m = 0;  ///< Height of the top edge (the floor it arrives at).
  Eigen::Vector2d uphill_dir = Eigen::Vector2d::UnitX();  ///< Unit, one of ±x, ±y.

  /// Horizontal length along uphill_dir [m].
  double Run() const;
  /// Inclination [rad].
  double SlopeRad() const { return std::atan2(z_high_m - z_low_m, Run()); }
  /// Width across uphill_dir [m].
  double Width() const;
  /// Whether (x, y) lies in the footprint, edges included.
  bool Contains(double x_m, double y_m) const;
  /// Height of the ramp's top surface over (x, y) [m] (clamped to the footprint along the run).
  double TopZAt(double x_m, double y_m) const;
};

/// A start/goal pair that plans on the scene (checked by tests at the scene's
/// assessment_resolution_m with the default GroundFilterConfig).
struct SceneQuery {
  std::string name;         ///< Short identifier, e.g. "ground_to_deck3".
  Eigen::Vector3d start_m;  ///< On the ground (z = ground height) [m].
  Eigen::Vector3d goal_m;   ///< On the ground (z = ground height) [m].
  std::string robot;        ///< Built-in profile it is meant for: "differential" or "biped".
};

// ---------------------------------------------------------------------------------------------

/// Forest on rolling terrain, x, y in [0, 40] m: the uneven_terrain height field scaled up (two
/// steep hills whose flanks pass 30°, 8–11 gentle hills and hollows, a low wave), 28–38 trees,
/// 16–22 partly buried rocks and 8–12 fallen logs (cylinders of radius 0.15–0.3 m, 3–6 m long,
/// lying on ground under 15°, clear of trunks, rocks and each other). The seed changes the
/// whole scene. Points lie in x, y in [0, 40] m (widened by the jitter), z roughly in [-4, 14] m.
/// At the default spacing 0.1 m: 250k–290k points. Coordinates: GetUnevenForestLayout.
PointCloud GenerateUnevenForest(std::uint32_t seed, double spacing_m = 0.1);

struct UnevenForestLayout {
  /// A log: a cylinder around the segment a→b, sunk by 20% of its radius into the ground.
  struct Log {
    Eigen::Vector3d a_m, b_m;  ///< Axis end points [m].
    double radius_m;           ///< In [0.15, 0.3].
  };
  UnevenTerrainLayout terrain;           ///< Ground, trees and rocks (size_m = 40).
  std::vector<Log> logs;                 ///< 8–12 logs.
  double assessment_resolution_m = 0.2;  ///< Grid resolution the queries are checked at.
  /// Corner to corner across the forest: gentle ground (< 8° within 1 m) clear of every
  /// object by 1.5 m, found near fixed anchors; plannable for the seeds the tests check.
  std::vector<SceneQuery> queries;
  /// Whether (x, y, z) lies inside a log [m].
  bool InsideLog(const Eigen::Vector3d& p_m) const;
};
UnevenForestLayout GetUnevenForestLayout(std::uint32_t seed);

// ---------------------------------------------------------------------------------------------

/// An abandoned station in a hall x in [0, 48] m, y in [0, 24] m, on three levels:
/// - the track bed (z = 0, y in [0, 8]) with three broken columns;
/// - the platform (z = 1.05, y in [8, 24], a solid block) reached from the track bed by two
///   11° ramps and two flights of stairs (7 risers of 0.15 m, not drivable);
/// - the mezzanine (top z = 4.05, underside 3.8, over y in [16, 24]: an overhang above the
///   back of the platform, on seven pillars) reached by an 11° ramp at each end, each arriving
///   on a tongue of the mezzanine.
/// Between x = 18 and 24 the mezzanine has collapsed: its slab hangs from the west part at 32°
/// onto a heap of rubble on the platform, so the mezzanine's two parts only connect through the
/// platform, and the platform under the collapse is not traversable. A back wall (y = 24)
/// closes the space under the mezzanine; 1 m parapets line the other elevated edges.
/// Points lie in the hall box (widened by the jitter), z in [0, 5.05] m. At the default spacing
/// 0.1 m: about 270k points. The seed only changes the jitter. Coordinates: StationLayout.
PointCloud GenerateAbandonedStation(std::uint32_t seed, double spacing_m = 0.1);

struct StationLayout {
  double x_max_m, y_max_m;         ///< The hall is [0, x_max] × [0, y_max].
  double track_z_m;                ///< Track bed height (0).
  double track_y_max_m;            ///< Track bed: y in [0, track_y_max].
  double platform_z_m;             ///< Platform top.
  double mezzanine_z_m;            ///< Mezzanine top.
  double mezzanine_underside_z_m;  ///< Mezzanine slab's lower face.
  double mezzanine_y_min_m;        ///< Mezzanine main part: y in [mezzanine_y_min, y_max].
  double collapse_x_min_m, collapse_x_max_m;  ///< Collapsed section: x in this range ...
  double collapse_y_min_m, collapse_y_max_m;  ///< ... and y in this range (platform level).
  double broken_slab_foot_x_m;                ///< Where the hanging slab meets the platform.
  double railing_height_m;                    ///< Railings and parapets above their floor.
  std::vector<SceneRamp> track_ramps;         ///< Track bed → platform (2).
  std::vector<SceneRamp> mezzanine_ramps;     ///< Platform → mezzanine: west, east.
  /// Tongues of the mezzanine the mezzanine ramps arrive on [x_min, x_max, y_min, y_max].
  std::vector<Eigen::Vector4d> tongues_m;
  /// Stairs track bed → platform, footprints [x_min, x_max, y_min, y_max], rising along +y.
  std::vector<Eigen::Vector4d> stairs_m;
  int stair_risers;                               ///< Risers per flight.
  double riser_m, tread_m;                        ///< Step height and depth.
  double pillar_radius_m;                         ///< Mezzanine pillars.
  std::vector<Eigen::Vector2d> pillar_centers_m;  ///< From the platform to the mezzanine.
  double column_radius_m;                         ///< Broken columns on the track bed.
  double column_height_m;                         ///< Their height above the track bed.
  std::vector<Eigen::Vector2d> column_centers_m;
  /// Rubble blocks on the platform in the collapsed section, [lo, hi] corners.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rubble_m;
  double assessment_resolution_m = 0.2;  ///< Grid resolution the queries are checked at.
  /// track_to_mezzanine_east, mezzanine_west_to_east (down one ramp, along the platform, up
  /// the other: the collapse cuts the direct way), under_mezzanine_to_track_east.
  std::vector<SceneQuery> queries;

  /// Whether the mezzanine (main part or a tongue, not the collapsed gap) lies over (x, y).
  bool IsOverMezzanine(double x_m, double y_m) const;
  /// Whether (x, y) lies in the collapsed section's footprint.
  bool InCollapse(double x_m, double y_m) const;
};
StationLayout GetStationLayout();

// ---------------------------------------------------------------------------------------------

/// A parking garage x in [0, 40] m, y in [0, 24] m with a ground floor (z = 0) and three decks
/// 2.8 m apart (z = 2.8, 5.6, 8.4; slabs 0.25 m thick, the top deck open to the sky). Three
/// straight 11° ramps (3.5 m wide, 14.4 m long) climb one storey each through an opening in
/// the deck above, alternating between the south and the north lane; walls run along each ramp
/// from its floor to 1 m above the deck it reaches, 1 m parapets along the decks' perimeter and
/// the openings' low ends. Square pillars (0.5 m) in two rows carry 0.45 m deep beams under
/// each deck (2.1 m clear below them); parked cars (1.9 × 4.4 × 1.4 m boxes) fill most bays of
/// a central row and of the lanes beside the ramps, differently on every level.
/// Points lie in the garage box (widened by the jitter), z in [0, 9.8] m (cars on the roof).
/// At the default spacing 0.16 m: about 390k points. The seed only changes the jitter.
/// Coordinates: GarageLayout.
PointCloud GenerateParkingGarage(std::uint32_t seed, double spacing_m = 0.16);

struct GarageLayout {
  double x_max_m, y_max_m;        ///< The garage is [0, x_max] × [0, y_max].
  std::vector<double> level_z_m;  ///< Floor heights, ground first (4 levels).
  double slab_thickness_m;        ///< Deck slab thickness (underside = level − this).
  double railing_height_m;        ///< Parapets and ramp walls above their deck.
  std::vector<SceneRamp> ramps;   ///< ramps[k] joins level k to level k + 1.
  double pillar_size_m;           ///< Square pillars' edge.
  std::vector<Eigen::Vector2d> pillar_centers_m;  ///< The same on every storey.
  double beam_depth_m, beam_width_m;              ///< Beams along x under every deck ...
  std::vector<double> beam_y_m;                   ///< ... centred at these y.
  /// Parked cars, boxes [lo, hi] (lo.z = the floor they stand on).
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> cars_m;
  double assessment_resolution_m = 0.2;  ///< Grid resolution the queries are checked at.
  /// ground_to_deck1, ground_to_roof (three ramps), across_deck2.
  std::vector<SceneQuery> queries;

  /// Whether level `level` (0 = ground) has floor over (x, y): inside the garage and not in
  /// the opening of the ramp that arrives there.
  bool HasFloor(int level, double x_m, double y_m) const;
};
GarageLayout GetGarageLayout();

// ---------------------------------------------------------------------------------------------

/// Two viaducts crossing over gently rolling ground, x, y in [0, 88] m. Viaduct A runs along x
/// (deck 5 m wide, top z = 4.5 m), viaduct B along y (top z = 7 m) and passes over A at the
/// centre (2.1 m clear between A's deck and B's underside). Decks are 0.4 m slabs on round
/// piers (radius 0.8 m) with 1 m railings on both sides; each viaduct comes down to the ground
/// at both ends on a 12° solid ramp. A straight road (6 m wide, flat) runs diagonally under the
/// crossing; a few low mounds (slopes under 9°) keep clear of the road and the viaducts.
/// Points lie in the square (widened by the jitter), z in [0, 8] m. At the default spacing
/// 0.16 m: about 380k points. The seed only changes the jitter. Coordinates: ViaductsLayout.
PointCloud GenerateCrossingViaducts(std::uint32_t seed, double spacing_m = 0.16);

struct ViaductsLayout {
  /// Adds height_m · exp(-|(x, y) - centre|² / (2 sigma_m²)) to the ground.
  struct Mound {
    double x_m, y_m, height_m, sigma_m;
  };
  double size_m;  ///< The ground covers [0, size] × [0, size].
  std::vector<Mound> mounds;
  double deck_width_m;  ///< Both viaducts.
  double deck_thickness_m;
  double railing_height_m;
  double a_z_m;                    ///< Viaduct A deck top.
  double a_y_min_m, a_y_max_m;     ///< A's deck: y in this range ...
  double a_x_min_m, a_x_max_m;     ///< ... from toe to toe (ramps included).
  double b_z_m;                    ///< Viaduct B deck top.
  double b_x_min_m, b_x_max_m;     ///< B's deck: x in this range ...
  double b_y_min_m, b_y_max_m;     ///< ... from toe to toe (ramps included).
  std::vector<SceneRamp> a_ramps;  ///< West, east.
  std::vector<SceneRamp> b_ramps;  ///< South, north.
  double pier_radius_m;
  std::vector<Eigen::Vector2d> a_piers_m;  ///< From the ground to A's underside.
  std::vector<Eigen::Vector2d> b_piers_m;  ///< From the ground to B's underside.
  Eigen::Vector2d road_point_m;            ///< The road's centre line passes here ...
  Eigen::Vector2d road_dir;                ///< ... along this unit direction ...
  double road_width_m;                     ///< ... with this width.
  double assessment_resolution_m = 0.2;    ///< Grid resolution the queries are checked at.
  /// along_road_under_crossing, ground_to_a_under_b, ground_to_b_over_a.
  std::vector<SceneQuery> queries;

  /// Ground height at (x, y) [m] (bare ground; not the ramps).
  double GroundZAt(double x_m, double y_m) const;
  /// Distance from (x, y) to the road's centre line [m].
  double RoadDistance(double x_m, double y_m) const;
  /// Deck top of A / B over (x, y) including its ramps, or NaN where it does not pass.
  double AZAt(double x_m, double y_m) const;
  double BZAt(double x_m, double y_m) const;
};
ViaductsLayout GetViaductsLayout();

// ---------------------------------------------------------------------------------------------

/// A room x in [0, 12] m, y in [0, 9] m, walls 2 m high, furnished with low tables (top
/// 0.54 m, underside 0.5 m, on four thin legs) and chairs (seat 0.45 m, backrest to 0.9 m).
/// A row of six tables spans the room wall to wall at y in [5, 5.8]: the back of the room is
/// reachable only under them, which the biped (body down to 0.35 m + 0.05 m headroom) can do
/// and the differential robot (0.5 m + 0.05 m) cannot. In front of the row stand two tables
/// with chairs, behind it one more. Points lie in the room box (widened by the jitter), z in
/// [0, 2] m. At the default spacing 0.05 m: about 100k points. The seed only changes the
/// jitter. Coordinates: IndoorTablesLayout.
PointCloud GenerateIndoorTables(std::uint32_t seed, double spacing_m = 0.05);

struct IndoorTablesLayout {
  /// A table: top [x_min, x_max] × [y_min, y_max] on four legs at its corners.
  struct Table {
    double x_min_m, x_max_m, y_min_m, y_max_m;
  };
  /// A chair: seat square centred at (x, y); the backrest stands on the side `back_dir`
  /// points to (a unit ±x or ±y).
  struct Chair {
    double x_m, y_m;
    Eigen::Vector2d back_dir;
  };
  double x_max_m, y_max_m;  ///< The room is [0, x_max] × [0, y_max].
  double wall_height_m;
  double table_underside_z_m;       ///< Every table's lower face.
  double table_top_z_m;             ///< Every table's upper face.
  double leg_radius_m;              ///< Table and chair legs.
  double leg_inset_m;               ///< Legs' axes this far inside the top's corners.
  double row_y_min_m, row_y_max_m;  ///< The row of tables spanning the room wall to wall.
  std::vector<Table> tables;        ///< The row first, then the free-standing tables.
  int row_tables;                   ///< How many of `tables` form the row.
  double chair_seat_size_m, chair_seat_z_m, chair_back_top_z_m;
  std::vector<Chair> chairs;
  double assessment_resolution_m = 0.1;  ///< Grid resolution the queries are checked at.
  /// front_around_tables (differential), under_the_row (biped; GOAL_UNREACHABLE for the
  /// differential robot), front_left_to_back_right (biped).
  std::vector<SceneQuery> queries;
  /// Whether (x, y) lies behind the row (reachable only under it).
  bool IsBehindRow(double /*x_m*/, double y_m) const { return y_m > row_y_max_m; }
};
IndoorTablesLayout GetIndoorTablesLayout();

}  // namespace strata
