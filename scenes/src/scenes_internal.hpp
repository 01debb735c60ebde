#pragma once
/// Shared by the scene generators (scenes/src/*.cpp); not installed. Seeded randomness without
/// the std distributions, the lattice sampler, and the terrain builder of uneven_terrain and
/// uneven_forest.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <numbers>
#include <random>

#include <Eigen/Core>

#include "strata/point_cloud.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/paper_scenes.hpp"

namespace strata::internal {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

/// Decides whether a sampled surface point is kept; used to clip a face to its visible part.
using KeepFn = std::function<bool(const Vec3&)>;

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegToRad = kPi / 180.0;

inline constexpr double kMinSpacingM = 0.01;
// Jitter bounds relative to the spacing and absolute in z: enough to break the perfect lattice
// (so nothing downstream relies on exact alignment) while staying well below the spacing.
inline constexpr double kJitterFraction = 0.1;
inline constexpr double kMaxJitterZM = 0.005;
// Tolerance for "strictly inside" tests on exact (unjittered) lattice coordinates.
inline constexpr double kEpsM = 1e-9;

// Streams of one seed: geometry placed by the seed and the jitter are drawn from independent
// engines, so changing the spacing (and with it the number of jitter draws) never moves a tree.
inline constexpr std::uint32_t kLayoutStream = 1;
inline constexpr std::uint32_t kJitterStream = 2;

inline std::mt19937 MakeEngine(std::uint32_t seed, std::uint32_t stream) {
  std::seed_seq seq{seed, stream};
  return std::mt19937(seq);
}

/// Uniform in [lo, hi). Written out because std::uniform_real_distribution differs between
/// standard libraries, which would make "same seed, same scene" platform dependent.
inline double Uniform(std::mt19937& rng, double lo, double hi) {
  constexpr double kInv2Pow32 = 1.0 / 4294967296.0;
  return lo + (hi - lo) * (static_cast<double>(rng()) * kInv2Pow32);
}

/// Integer in [lo, hi]; the modulo bias is negligible for the small ranges used here.
inline int UniformInt(std::mt19937& rng, int lo, int hi) {
  return lo + static_cast<int>(rng() % static_cast<std::uint32_t>(hi - lo + 1));
}

inline bool IsValidSpacing(double spacing_m) {
  return std::isfinite(spacing_m) && spacing_m >= kMinSpacingM;
}

/// Number of lattice intervals along a segment: the spacing is rounded so both ends are sampled.
inline int Intervals(double length_m, double spacing_m) {
  if (length_m < kEpsM) return 0;
  return std::max(1, static_cast<int>(std::lround(length_m / spacing_m)));
}

inline bool StrictlyInside(double v, double lo, double hi) {
  return v > lo + kEpsM && v < hi - kEpsM;
}

/// Samples surfaces into a point cloud on a lattice at about `spacing_m`, with seeded jitter.
class SurfaceSampler {
 public:
  SurfaceSampler(std::uint32_t seed, double spacing_m);

  /// A sampler that only counts the lattice points offered to it, without consulting `keep`:
  /// an upper bound of what a sampler at the same spacing keeps, to reserve its cloud.
  static SurfaceSampler Counter(double spacing_m);

  double spacing_m() const { return spacing_m_; }

  /// The points a Counter was offered so far.
  std::size_t counted() const { return counted_; }

  /// Reserves room for `points` points, so that a cloud of known size is never reallocated.
  void Reserve(std::size_t points) { cloud_.reserve(points); }

  /// Adds p (exact surface point) with jitter.
  void AddPoint(const Vec3& p) {
    if (counting_) {
      ++counted_;
      return;
    }
    // Jitter is drawn only for kept points, always in the order x, y, z.
    const double dx = Uniform(rng_, -jitter_xy_m_, jitter_xy_m_);
    const double dy = Uniform(rng_, -jitter_xy_m_, jitter_xy_m_);
    const double dz = Uniform(rng_, -jitter_z_m_, jitter_z_m_);
    cloud_.emplace_back(static_cast<float>(p.x() + dx), static_cast<float>(p.y() + dy),
                        static_cast<float>(p.z() + dz));
  }

  /// Adds p with jitter if keep accepts it (or keep is empty).
  void AddPoint(const Vec3& p, const KeepFn& keep) {
    if (!counting_ && keep && !keep(p)) return;
    AddPoint(p);
  }

  /// A ruled patch between segment a0→a1 and segment b0→b1: columns every spacing along the
  /// longer of the two, each column sampled every spacing from a(u) to b(u). Covers
  /// rectangles, parallelograms and (with a degenerate edge) triangles and trapezoids.
  void AddRuledPatch(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                     const KeepFn& keep = {});

  /// The horizontal rectangle [x0, x1] × [y0, y1] at height z.
  void AddHorizontalRect(double x0, double x1, double y0, double y1, double z,
                         const KeepFn& keep = {});

  /// A vertical rectangle above the ground segment a→b, from z0 to z1.
  void AddVerticalRect(const Vec2& a, const Vec2& b, double z0, double z1, const KeepFn& keep = {});

  /// A vertical trapezoid above the ground segment a→b: bottom at z_base, top edge rising
  /// linearly from z_top_a over a to z_top_b over b (a triangle when z_top_a == z_base). The
  /// side face of a solid ramp.
  void AddVerticalTrapezoid(const Vec2& a, const Vec2& b, double z_base, double z_top_a,
                            double z_top_b, const KeepFn& keep = {});

  /// The inclined rectangle whose low edge is a→b at z_low and which rises by `rise` over the
  /// horizontal run `run_dir` (not necessarily unit; its length is the run).
  void AddInclinedRect(const Vec2& a, const Vec2& b, double z_low, const Vec2& run_dir, double rise,
                       const KeepFn& keep = {});

  /// The faces of the axis-aligned box [lo, hi]: top, four sides and, if asked, the bottom.
  void AddBoxSurfaces(const Vec3& lo, const Vec3& hi, bool with_bottom, const KeepFn& keep = {});

  /// The mantle of the vertical cylinder of radius r around (cx, cy), from z0 to z1 (no caps).
  void AddVerticalCylinder(double cx, double cy, double r, double z0, double z1,
                           const KeepFn& keep = {});

  /// The mantle of the cylinder of radius r around the segment a→b (any direction). A log.
  void AddCylinder(const Vec3& a, const Vec3& b, double r, const KeepFn& keep = {});

  /// The disc of radius r around `center` across `normal` (without its rim). A log's end.
  void AddDisc(const Vec3& center, const Vec3& normal, double r, const KeepFn& keep = {});

  /// The surface of an ellipsoid round in plan (radius r_xy) with vertical radius r_z; a
  /// sphere when they are equal. Rings of constant latitude, each sampled at about the spacing.
  void AddEllipsoid(const Vec3& center, double r_xy, double r_z, const KeepFn& keep = {});

  /// The height field z = height(x, y) over [x0, x1] × [y0, y1], on the horizontal lattice.
  void AddHeightField(double x0, double x1, double y0, double y1,
                      const std::function<double(double, double)>& height, const KeepFn& keep = {});

  PointCloud TakeCloud() && { return std::move(cloud_); }

 private:
  std::mt19937 rng_;
  double spacing_m_;
  double jitter_xy_m_;
  double jitter_z_m_;
  bool counting_ = false;
  std::size_t counted_ = 0;
  PointCloud cloud_;
};

/// The four walls of the room [0, x_max] × [0, y_max], from z0 to z1.
void AddRoomWalls(SurfaceSampler& sampler, double x_max, double y_max, double z0, double z1,
                  const KeepFn& keep);

/// A solid ramp (a wedge on the floor it starts from): its inclined top and, if asked, its two
/// side faces from the floor up to the top plus `side_extra_m` (> 0: a railing sheet standing
/// on the ramp's edge; 0: the bare side face) and the vertical back face under its high end
/// down to `back_bottom_z_m` (pass ramp.z_high_m for none). Points are kept only where `keep`
/// accepts them.
void AddSolidRamp(SurfaceSampler& s, const SceneRamp& ramp, bool with_sides, double side_extra_m,
                  double back_bottom_z_m, const KeepFn& keep = {});

/// How the uneven-terrain family draws its layout; the values of uneven_terrain are the
/// defaults, so GetUnevenTerrainLayout is BuildTerrainLayout(rng, {}).
struct TerrainParams {
  double size_m = 30.0;
  int steep_hills = 1;  ///< Drawn first, centres in [0.3, 0.7]·size.
  double steep_height_min_m = 3.0, steep_height_max_m = 4.0;
  double steep_sigma_min_m = 2.0, steep_sigma_max_m = 2.5;
  int gentle_hills_min = 5, gentle_hills_max = 7;
  double gentle_height_min_m = 0.5, gentle_height_max_m = 2.0;
  double gentle_sigma_min_m = 3.0, gentle_sigma_max_m = 6.0;
  double hollow_probability = 0.35;
  double wave_amplitude_m = 0.15, wave_length_m = 12.0;
  int trees_min = 15, trees_max = 25;
  int rocks_min = 10, rocks_max = 15;
};

/// Draws hills, the wave, trees and rocks from `rng` in that order (see GetUnevenTerrainLayout).
UnevenTerrainLayout BuildTerrainLayout(std::mt19937& rng, const TerrainParams& params);

/// Whether p lies inside a rock of `l` / inside a trunk or crown of `l`.
bool InsideRock(const UnevenTerrainLayout& l, const Vec3& p);
bool InsideTree(const UnevenTerrainLayout& l, const Vec3& p);

/// Samples the ground, trees and rocks of `l`; `in_extra_solid` (may be empty) hides further
/// ground and object points (the forest's logs).
void SampleTerrain(SurfaceSampler& s, const UnevenTerrainLayout& l, const KeepFn& in_extra_solid);

/// An upper bound of GenerateOutdoorSite's points (every lattice point it offers, kept or not),
/// counted without sampling; what it reserves.
std::size_t OutdoorSitePointBound(std::uint32_t seed, double size_m, double spacing_m);

}  // namespace strata::internal
