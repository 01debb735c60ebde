#include "strata/scenes.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <utility>

namespace strata {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

/// Decides whether a sampled surface point is kept; used to clip a face to its visible part.
using KeepFn = std::function<bool(const Vec3&)>;

constexpr double kPi = std::numbers::pi;
constexpr double kDegToRad = kPi / 180.0;

constexpr double kMinSpacingM = 0.01;
// Jitter bounds relative to the spacing and absolute in z: enough to break the perfect lattice
// (so nothing downstream relies on exact alignment) while staying well below the spacing.
constexpr double kJitterFraction = 0.1;
constexpr double kMaxJitterZM = 0.005;
// Tolerance for "strictly inside" tests on exact (unjittered) lattice coordinates.
constexpr double kEpsM = 1e-9;

// Streams of one seed: geometry placed by the seed and the jitter are drawn from independent
// engines, so changing the spacing (and with it the number of jitter draws) never moves a tree.
constexpr std::uint32_t kLayoutStream = 1;
constexpr std::uint32_t kJitterStream = 2;

std::mt19937 MakeEngine(std::uint32_t seed, std::uint32_t stream) {
  std::seed_seq seq{seed, stream};
  return std::mt19937(seq);
}

// Uniform in [lo, hi). Written out because std::uniform_real_distribution differs between
// standard libraries, which would make "same seed, same scene" platform dependent.
double Uniform(std::mt19937& rng, double lo, double hi) {
  constexpr double kInv2Pow32 = 1.0 / 4294967296.0;
  return lo + (hi - lo) * (static_cast<double>(rng()) * kInv2Pow32);
}

// Integer in [lo, hi]; the modulo bias is negligible for the small ranges used here.
int UniformInt(std::mt19937& rng, int lo, int hi) {
  return lo + static_cast<int>(rng() % static_cast<std::uint32_t>(hi - lo + 1));
}

bool IsValidSpacing(double spacing_m) {
  return std::isfinite(spacing_m) && spacing_m >= kMinSpacingM;
}

// Number of lattice intervals along a segment: the spacing is rounded so both ends are sampled.
int Intervals(double length_m, double spacing_m) {
  if (length_m < kEpsM) return 0;
  return std::max(1, static_cast<int>(std::lround(length_m / spacing_m)));
}

bool StrictlyInside(double v, double lo, double hi) { return v > lo + kEpsM && v < hi - kEpsM; }

/// Samples surfaces into a point cloud on a lattice at about `spacing_m`, with seeded jitter.
class SurfaceSampler {
 public:
  SurfaceSampler(std::uint32_t seed, double spacing_m)
      : rng_(MakeEngine(seed, kJitterStream)),
        spacing_m_(spacing_m),
        jitter_xy_m_(kJitterFraction * spacing_m),
        jitter_z_m_(std::min(kMaxJitterZM, kJitterFraction * spacing_m)) {}

  /// Adds p (exact surface point) with jitter if keep accepts it (or keep is empty).
  void AddPoint(const Vec3& p, const KeepFn& keep) {
    if (keep && !keep(p)) return;
    // Jitter is drawn only for kept points, always in the order x, y, z.
    const double dx = Uniform(rng_, -jitter_xy_m_, jitter_xy_m_);
    const double dy = Uniform(rng_, -jitter_xy_m_, jitter_xy_m_);
    const double dz = Uniform(rng_, -jitter_z_m_, jitter_z_m_);
    cloud_.emplace_back(static_cast<float>(p.x() + dx), static_cast<float>(p.y() + dy),
                        static_cast<float>(p.z() + dz));
  }

  /// A ruled patch between segment a0→a1 and segment b0→b1: columns every spacing along the
  /// longer of the two, each column sampled every spacing from a(u) to b(u). Covers
  /// rectangles, parallelograms and (with a degenerate edge) triangles and trapezoids.
  void AddRuledPatch(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                     const KeepFn& keep = {}) {
    const int nu = Intervals(std::max((a1 - a0).norm(), (b1 - b0).norm()), spacing_m_);
    for (int i = 0; i <= nu; ++i) {
      const double u = nu == 0 ? 0.0 : static_cast<double>(i) / nu;
      const Vec3 a = a0 + u * (a1 - a0);
      const Vec3 b = b0 + u * (b1 - b0);
      const int nv = Intervals((b - a).norm(), spacing_m_);
      for (int j = 0; j <= nv; ++j) {
        const double v = nv == 0 ? 0.0 : static_cast<double>(j) / nv;
        AddPoint(a + v * (b - a), keep);
      }
    }
  }

  /// The horizontal rectangle [x0, x1] × [y0, y1] at height z.
  void AddHorizontalRect(double x0, double x1, double y0, double y1, double z,
                         const KeepFn& keep = {}) {
    AddRuledPatch({x0, y0, z}, {x1, y0, z}, {x0, y1, z}, {x1, y1, z}, keep);
  }

  /// A vertical rectangle above the ground segment a→b, from z0 to z1.
  void AddVerticalRect(const Vec2& a, const Vec2& b, double z0, double z1,
                       const KeepFn& keep = {}) {
    AddRuledPatch({a.x(), a.y(), z0}, {b.x(), b.y(), z0}, {a.x(), a.y(), z1}, {b.x(), b.y(), z1},
                  keep);
  }

  /// A vertical trapezoid above the ground segment a→b: bottom at z_base, top edge rising
  /// linearly from z_top_a over a to z_top_b over b (a triangle when z_top_a == z_base). The
  /// side face of a solid ramp.
  void AddVerticalTrapezoid(const Vec2& a, const Vec2& b, double z_base, double z_top_a,
                            double z_top_b, const KeepFn& keep = {}) {
    AddRuledPatch({a.x(), a.y(), z_base}, {b.x(), b.y(), z_base}, {a.x(), a.y(), z_top_a},
                  {b.x(), b.y(), z_top_b}, keep);
  }

  /// The inclined rectangle whose low edge is a→b at z_low and which rises by `rise` over the
  /// horizontal run `run_dir` (not necessarily unit; its length is the run).
  void AddInclinedRect(const Vec2& a, const Vec2& b, double z_low, const Vec2& run_dir, double rise,
                       const KeepFn& keep = {}) {
    const Vec2 a_high = a + run_dir;
    const Vec2 b_high = b + run_dir;
    AddRuledPatch({a.x(), a.y(), z_low}, {b.x(), b.y(), z_low},
                  {a_high.x(), a_high.y(), z_low + rise}, {b_high.x(), b_high.y(), z_low + rise},
                  keep);
  }

  /// The faces of the axis-aligned box [lo, hi]: top, four sides and, if asked, the bottom.
  void AddBoxSurfaces(const Vec3& lo, const Vec3& hi, bool with_bottom, const KeepFn& keep = {}) {
    AddHorizontalRect(lo.x(), hi.x(), lo.y(), hi.y(), hi.z(), keep);
    if (with_bottom) AddHorizontalRect(lo.x(), hi.x(), lo.y(), hi.y(), lo.z(), keep);
    const Vec2 c00(lo.x(), lo.y()), c10(hi.x(), lo.y()), c11(hi.x(), hi.y()), c01(lo.x(), hi.y());
    AddVerticalRect(c00, c10, lo.z(), hi.z(), keep);
    AddVerticalRect(c10, c11, lo.z(), hi.z(), keep);
    AddVerticalRect(c11, c01, lo.z(), hi.z(), keep);
    AddVerticalRect(c01, c00, lo.z(), hi.z(), keep);
  }

  /// The mantle of the vertical cylinder of radius r around (cx, cy), from z0 to z1 (no caps).
  void AddVerticalCylinder(double cx, double cy, double r, double z0, double z1,
                           const KeepFn& keep = {}) {
    // At least 8 columns, so a thin leg still reads as round rather than as a line.
    const int n_around = std::max(8, Intervals(2.0 * kPi * r, spacing_m_));
    const int n_up = Intervals(z1 - z0, spacing_m_);
    for (int i = 0; i < n_around; ++i) {
      const double phi = 2.0 * kPi * i / n_around;
      const double x = cx + r * std::cos(phi);
      const double y = cy + r * std::sin(phi);
      for (int j = 0; j <= n_up; ++j) {
        AddPoint({x, y, z0 + (z1 - z0) * (n_up == 0 ? 0.0 : static_cast<double>(j) / n_up)}, keep);
      }
    }
  }

  /// The surface of an ellipsoid round in plan (radius r_xy) with vertical radius r_z; a
  /// sphere when they are equal. Rings of constant latitude, each sampled at about the spacing.
  void AddEllipsoid(const Vec3& center, double r_xy, double r_z, const KeepFn& keep = {}) {
    const int n_lat = std::max(2, Intervals(kPi * std::max(r_xy, r_z), spacing_m_));
    for (int i = 0; i <= n_lat; ++i) {
      const double theta = kPi * i / n_lat;  // 0 at the top pole.
      const double ring_r = r_xy * std::sin(theta);
      const double z = center.z() + r_z * std::cos(theta);
      const int n_around = std::max(1, Intervals(2.0 * kPi * ring_r, spacing_m_));
      for (int k = 0; k < n_around; ++k) {
        const double phi = 2.0 * kPi * k / n_around;
        AddPoint({center.x() + ring_r * std::cos(phi), center.y() + ring_r * std::sin(phi), z},
                 keep);
      }
    }
  }

  /// The height field z = height(x, y) over [x0, x1] × [y0, y1], on the horizontal lattice.
  void AddHeightField(double x0, double x1, double y0, double y1,
                      const std::function<double(double, double)>& height,
                      const KeepFn& keep = {}) {
    const int nx = Intervals(x1 - x0, spacing_m_);
    const int ny = Intervals(y1 - y0, spacing_m_);
    for (int i = 0; i <= nx; ++i) {
      const double x = x0 + (x1 - x0) * (nx == 0 ? 0.0 : static_cast<double>(i) / nx);
      for (int j = 0; j <= ny; ++j) {
        const double y = y0 + (y1 - y0) * (ny == 0 ? 0.0 : static_cast<double>(j) / ny);
        AddPoint({x, y, height(x, y)}, keep);
      }
    }
  }

  PointCloud TakeCloud() && { return std::move(cloud_); }

 private:
  std::mt19937 rng_;
  double spacing_m_;
  double jitter_xy_m_;
  double jitter_z_m_;
  PointCloud cloud_;
};

/// The four walls of the room [0, x_max] × [0, y_max], from z0 to z1.
void AddRoomWalls(SurfaceSampler& sampler, double x_max, double y_max, double z0, double z1,
                  const KeepFn& keep) {
  const Vec2 c00(0.0, 0.0), c10(x_max, 0.0), c11(x_max, y_max), c01(0.0, y_max);
  sampler.AddVerticalRect(c00, c10, z0, z1, keep);
  sampler.AddVerticalRect(c10, c11, z0, z1, keep);
  sampler.AddVerticalRect(c11, c01, z0, z1, keep);
  sampler.AddVerticalRect(c01, c00, z0, z1, keep);
}

// Stairs room.
constexpr double kRoomXM = 8.0;
constexpr double kRoomYM = 7.0;
constexpr double kRoomWallHeightM = 2.0;
constexpr double kRiserM = 0.15;
constexpr double kTreadM = 0.25;
constexpr int kStairRisers = 6;
constexpr double kLandingZM = kStairRisers * kRiserM;
constexpr double kLandingDepthM = 1.0;
constexpr double kStairsXMinM = 3.7;
constexpr double kStairsWidthM = 1.2;
constexpr double kRampXMinM = 1.0;
constexpr double kRampWidthM = 1.5;
constexpr double kRoomRampSlopeDeg = 10.0;
constexpr double kShelfXMinM = 5.9;
constexpr double kShelfYMinM = 2.2;
constexpr double kShelfSizeXM = 1.2;
constexpr double kShelfSizeYM = 0.8;
constexpr double kShelfUndersideZM = 0.25;
constexpr double kShelfThicknessM = 0.05;
constexpr double kShelfLegRadiusM = 0.02;
constexpr double kShelfLegInsetM = 0.06;

// Two-level hall.
constexpr double kHallXM = 20.0;
constexpr double kHallYM = 12.0;
constexpr double kHallWallHeightM = 4.0;
constexpr double kDeckZM = 3.0;
constexpr double kDeckThicknessM = 0.2;
constexpr double kDeckYMinM = 6.5;
constexpr double kHallRampSlopeDeg = 12.0;
constexpr double kHallRampXMaxM = 16.5;
constexpr double kHallRampYMinM = 1.5;
constexpr double kHallRampWidthM = 2.5;
constexpr double kRailingHeightM = 1.0;
constexpr double kPillarRadiusM = 0.3;

// Uneven terrain.
constexpr double kTerrainSizeM = 30.0;
// Below the ground at a trunk's foot the trunk is started this deep, so it meets the terrain on
// the downhill side as well; the part below ground is clipped.
constexpr double kTrunkFootDepthM = 0.5;
// Fraction of a rock's vertical radius that is buried, so rocks sit in the ground, not on it.
constexpr double kRockBuriedFraction = 0.2;

}  // namespace

StairsRampLayout GetStairsRampLayout() {
  StairsRampLayout l{};
  l.room_x_max_m = kRoomXM;
  l.room_y_max_m = kRoomYM;
  l.wall_height_m = kRoomWallHeightM;
  l.landing_z_m = kLandingZM;
  l.landing_y_min_m = kRoomYM - kLandingDepthM;
  l.riser_m = kRiserM;
  l.tread_m = kTreadM;
  l.stair_risers = kStairRisers;
  l.stairs_x_min_m = kStairsXMinM;
  l.stairs_x_max_m = kStairsXMinM + kStairsWidthM;
  // n risers need n - 1 treads: the top riser ends flush with the landing's front edge.
  l.stairs_y_max_m = l.landing_y_min_m;
  l.stairs_y_min_m = l.stairs_y_max_m - (kStairRisers - 1) * kTreadM;
  l.ramp_slope_rad = kRoomRampSlopeDeg * kDegToRad;
  l.ramp_x_min_m = kRampXMinM;
  l.ramp_x_max_m = kRampXMinM + kRampWidthM;
  l.ramp_y_max_m = l.landing_y_min_m;
  l.ramp_y_min_m = l.ramp_y_max_m - kLandingZM / std::tan(l.ramp_slope_rad);
  l.shelf_x_min_m = kShelfXMinM;
  l.shelf_x_max_m = kShelfXMinM + kShelfSizeXM;
  l.shelf_y_min_m = kShelfYMinM;
  l.shelf_y_max_m = kShelfYMinM + kShelfSizeYM;
  l.shelf_underside_z_m = kShelfUndersideZM;
  l.shelf_top_z_m = kShelfUndersideZM + kShelfThicknessM;
  return l;
}

PointCloud GenerateStairsRampRoom(std::uint32_t seed, double spacing_m) {
  if (!IsValidSpacing(spacing_m)) return {};
  const StairsRampLayout l = GetStairsRampLayout();
  SurfaceSampler s(seed, spacing_m);

  const auto in_stairs_xy = [&l](double x, double y) {
    return StrictlyInside(x, l.stairs_x_min_m, l.stairs_x_max_m) &&
           StrictlyInside(y, l.stairs_y_min_m, l.stairs_y_max_m);
  };
  const auto in_ramp_xy = [&l](double x, double y) {
    return StrictlyInside(x, l.ramp_x_min_m, l.ramp_x_max_m) &&
           StrictlyInside(y, l.ramp_y_min_m, l.ramp_y_max_m);
  };

  // Floor, except under the stairs and the ramp (solids). The landing is solid too; the floor
  // is sampled only up to its front face.
  s.AddHorizontalRect(0.0, l.room_x_max_m, 0.0, l.landing_y_min_m, 0.0, [&](const Vec3& p) {
    return !in_stairs_xy(p.x(), p.y()) && !in_ramp_xy(p.x(), p.y());
  });
  // Walls, except where they are behind the solid landing.
  AddRoomWalls(s, l.room_x_max_m, l.room_y_max_m, 0.0, l.wall_height_m, [&l](const Vec3& p) {
    return !(p.y() > l.landing_y_min_m + kEpsM && p.z() < l.landing_z_m - kEpsM);
  });

  // Landing: top and front face; the front face is hidden where the stairs and ramp abut it.
  s.AddHorizontalRect(0.0, l.room_x_max_m, l.landing_y_min_m, l.room_y_max_m, l.landing_z_m);
  s.AddVerticalRect({0.0, l.landing_y_min_m}, {l.room_x_max_m, l.landing_y_min_m}, 0.0,
                    l.landing_z_m, [&](const Vec3& p) {
                      return !StrictlyInside(p.x(), l.stairs_x_min_m, l.stairs_x_max_m) &&
                             !StrictlyInside(p.x(), l.ramp_x_min_m, l.ramp_x_max_m);
                    });

  // Stairs: riser k rises from k·riser to (k+1)·riser; tread k (below the landing) tops it.
  // The side faces are the stepped profile under the treads.
  for (int k = 0; k < l.stair_risers; ++k) {
    const double y = l.stairs_y_min_m + k * l.tread_m;
    s.AddVerticalRect({l.stairs_x_min_m, y}, {l.stairs_x_max_m, y}, k * l.riser_m,
                      (k + 1) * l.riser_m);
    if (k + 1 < l.stair_risers) {
      s.AddHorizontalRect(l.stairs_x_min_m, l.stairs_x_max_m, y, y + l.tread_m,
                          (k + 1) * l.riser_m);
    }
  }
  const auto below_stairs_profile = [&l](const Vec3& p) {
    const int step = static_cast<int>(std::floor((p.y() - l.stairs_y_min_m) / l.tread_m + kEpsM));
    const double top = std::min(step + 1, l.stair_risers) * l.riser_m;
    return p.z() <= top + kEpsM;
  };
  for (const double x : {l.stairs_x_min_m, l.stairs_x_max_m}) {
    s.AddVerticalRect({x, l.stairs_y_min_m}, {x, l.stairs_y_max_m}, 0.0, l.landing_z_m,
                      below_stairs_profile);
  }

  // Ramp: a solid wedge, top surface and the two triangular sides.
  const Vec2 ramp_run(0.0, l.ramp_y_max_m - l.ramp_y_min_m);
  s.AddInclinedRect({l.ramp_x_min_m, l.ramp_y_min_m}, {l.ramp_x_max_m, l.ramp_y_min_m}, 0.0,
                    ramp_run, l.landing_z_m);
  for (const double x : {l.ramp_x_min_m, l.ramp_x_max_m}) {
    s.AddVerticalTrapezoid({x, l.ramp_y_min_m}, {x, l.ramp_y_max_m}, 0.0, 0.0, l.landing_z_m);
  }

  // Shelf: a slab with both faces sampled (the underside is the overhang the filter must
  // see) on four thin legs.
  s.AddBoxSurfaces({l.shelf_x_min_m, l.shelf_y_min_m, l.shelf_underside_z_m},
                   {l.shelf_x_max_m, l.shelf_y_max_m, l.shelf_top_z_m}, /*with_bottom=*/true);
  for (const double x : {l.shelf_x_min_m + kShelfLegInsetM, l.shelf_x_max_m - kShelfLegInsetM}) {
    for (const double y : {l.shelf_y_min_m + kShelfLegInsetM, l.shelf_y_max_m - kShelfLegInsetM}) {
      s.AddVerticalCylinder(x, y, kShelfLegRadiusM, 0.0, l.shelf_underside_z_m);
    }
  }
  return std::move(s).TakeCloud();
}

bool TwoLevelRampLayout::IsOverDeck(double x_m, double y_m) const {
  const bool in_hall = x_m >= 0.0 && x_m <= room_x_max_m && y_m >= 0.0 && y_m <= room_y_max_m;
  return in_hall && (y_m >= deck_y_min_m || x_m >= deck_tongue_x_min_m);
}

TwoLevelRampLayout GetTwoLevelRampLayout() {
  TwoLevelRampLayout l{};
  l.room_x_max_m = kHallXM;
  l.room_y_max_m = kHallYM;
  l.wall_height_m = kHallWallHeightM;
  l.floor_z_m = 0.0;
  l.deck_z_m = kDeckZM;
  l.deck_underside_z_m = kDeckZM - kDeckThicknessM;
  l.deck_y_min_m = kDeckYMinM;
  // The tongue's edge is where the ramp arrives.
  l.deck_tongue_x_min_m = kHallRampXMaxM;
  l.ramp_slope_rad = kHallRampSlopeDeg * kDegToRad;
  l.ramp_x_max_m = kHallRampXMaxM;
  l.ramp_x_min_m = kHallRampXMaxM - (kDeckZM - l.floor_z_m) / std::tan(l.ramp_slope_rad);
  l.ramp_y_min_m = kHallRampYMinM;
  l.ramp_y_max_m = kHallRampYMinM + kHallRampWidthM;
  l.ramp_uphill_dir = Vec2(1.0, 0.0);
  l.railing_height_m = kRailingHeightM;
  l.pillar_radius_m = kPillarRadiusM;
  // Three under the main deck, two under the tongue beside the ramp's back face.
  const double main_mid_y = 0.5 * (kDeckYMinM + kHallYM);
  const double tongue_mid_x = 0.5 * (kHallRampXMaxM + kHallXM);
  l.pillar_centers_m = {{4.0, main_mid_y},
                        {9.5, main_mid_y},
                        {15.0, main_mid_y},
                        {tongue_mid_x, 0.8},
                        {tongue_mid_x, 5.0}};
  // Start: open floor between the ramp and the deck edge, before the ramp's toe. Goal: the
  // main deck, which is only reachable via the ramp and the tongue.
  l.start_example_m = Vec3(1.0, 0.5 * (l.ramp_y_max_m + kDeckYMinM), l.floor_z_m);
  l.goal_example_m = Vec3(7.0, main_mid_y, kDeckZM);
  return l;
}

PointCloud GenerateTwoLevelRamp(std::uint32_t seed, double spacing_m) {
  if (!IsValidSpacing(spacing_m)) return {};
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  SurfaceSampler s(seed, spacing_m);

  const auto in_ramp_xy = [&l](double x, double y) {
    return StrictlyInside(x, l.ramp_x_min_m, l.ramp_x_max_m) &&
           StrictlyInside(y, l.ramp_y_min_m, l.ramp_y_max_m);
  };
  const auto in_pillar_xy = [&l](double x, double y) {
    return std::any_of(l.pillar_centers_m.begin(), l.pillar_centers_m.end(), [&](const Vec2& c) {
      return (Vec2(x, y) - c).norm() < l.pillar_radius_m - kEpsM;
    });
  };
  const auto beside_ramp_top = [&l](const Vec3& p) {
    return !StrictlyInside(p.y(), l.ramp_y_min_m, l.ramp_y_max_m);
  };

  // Floor, except under the ramp and the pillars.
  s.AddHorizontalRect(0.0, l.room_x_max_m, 0.0, l.room_y_max_m, l.floor_z_m, [&](const Vec3& p) {
    return !in_ramp_xy(p.x(), p.y()) && !in_pillar_xy(p.x(), p.y());
  });
  // Outer walls, except within the slab's thickness where the deck abuts them.
  AddRoomWalls(s, l.room_x_max_m, l.room_y_max_m, l.floor_z_m, l.wall_height_m,
               [&l](const Vec3& p) {
                 return !(l.IsOverDeck(p.x(), p.y()) &&
                          StrictlyInside(p.z(), l.deck_underside_z_m, l.deck_z_m));
               });

  // Deck: main strip plus tongue, top and underside. The tongue stops short of the edge it
  // shares with the main strip so that edge is sampled once; the underside is hidden where
  // the pillars meet it.
  const auto add_deck_face = [&](double z, const KeepFn& keep) {
    s.AddHorizontalRect(0.0, l.room_x_max_m, l.deck_y_min_m, l.room_y_max_m, z, keep);
    s.AddHorizontalRect(
        l.deck_tongue_x_min_m, l.room_x_max_m, 0.0, l.deck_y_min_m, z,
        [&](const Vec3& p) { return p.y() < l.deck_y_min_m - kEpsM && (!keep || keep(p)); });
  };
  add_deck_face(l.deck_z_m, {});
  add_deck_face(l.deck_underside_z_m, [&](const Vec3& p) { return !in_pillar_xy(p.x(), p.y()); });
  // Open deck edges: the slab's edge face and the railing above it form one vertical sheet,
  // interrupted where the ramp arrives.
  const double sheet_top_z = l.deck_z_m + l.railing_height_m;
  s.AddVerticalRect({0.0, l.deck_y_min_m}, {l.deck_tongue_x_min_m, l.deck_y_min_m},
                    l.deck_underside_z_m, sheet_top_z);
  s.AddVerticalRect({l.deck_tongue_x_min_m, 0.0}, {l.deck_tongue_x_min_m, l.deck_y_min_m},
                    l.deck_underside_z_m, sheet_top_z, beside_ramp_top);

  // Ramp: a solid wedge; top, two triangular sides and the back face under the tongue.
  const double rise = l.deck_z_m - l.floor_z_m;
  const Vec2 ramp_run = (l.ramp_x_max_m - l.ramp_x_min_m) * l.ramp_uphill_dir;
  s.AddInclinedRect({l.ramp_x_min_m, l.ramp_y_min_m}, {l.ramp_x_min_m, l.ramp_y_max_m}, l.floor_z_m,
                    ramp_run, rise);
  for (const double y : {l.ramp_y_min_m, l.ramp_y_max_m}) {
    s.AddVerticalTrapezoid({l.ramp_x_min_m, y}, {l.ramp_x_max_m, y}, l.floor_z_m, l.floor_z_m,
                           l.deck_z_m);
  }
  s.AddVerticalRect({l.ramp_x_max_m, l.ramp_y_min_m}, {l.ramp_x_max_m, l.ramp_y_max_m}, l.floor_z_m,
                    l.deck_underside_z_m);

  for (const Vec2& c : l.pillar_centers_m) {
    s.AddVerticalCylinder(c.x(), c.y(), l.pillar_radius_m, l.floor_z_m, l.deck_underside_z_m);
  }
  return std::move(s).TakeCloud();
}

double UnevenTerrainLayout::HeightAt(double x_m, double y_m) const {
  double z = 0.0;
  for (const Hill& h : hills) {
    const double dx = x_m - h.x_m;
    const double dy = y_m - h.y_m;
    z += h.height_m * std::exp(-(dx * dx + dy * dy) / (2.0 * h.sigma_m * h.sigma_m));
  }
  const double k = 2.0 * kPi / wave_length_m;
  z += wave_amplitude_m * std::sin(k * x_m + wave_phase_x_rad) *
       std::sin(k * y_m + wave_phase_y_rad);
  return z;
}

Eigen::Vector2d UnevenTerrainLayout::GradientAt(double x_m, double y_m) const {
  Vec2 g = Vec2::Zero();
  for (const Hill& h : hills) {
    const Vec2 d(x_m - h.x_m, y_m - h.y_m);
    const double s2 = h.sigma_m * h.sigma_m;
    g -= h.height_m * std::exp(-d.squaredNorm() / (2.0 * s2)) / s2 * d;
  }
  const double k = 2.0 * kPi / wave_length_m;
  const double sx = std::sin(k * x_m + wave_phase_x_rad), cx = std::cos(k * x_m + wave_phase_x_rad);
  const double sy = std::sin(k * y_m + wave_phase_y_rad), cy = std::cos(k * y_m + wave_phase_y_rad);
  g += wave_amplitude_m * k * Vec2(cx * sy, sx * cy);
  return g;
}

UnevenTerrainLayout GetUnevenTerrainLayout(std::uint32_t seed) {
  // Hills: one steep hill so every seed has slopes beyond 30° (a Gaussian's steepest slope is
  // height/sigma·e^(-1/2), here >= 0.73, i.e. >= 36°), then gentler hills and hollows
  // (<= 2/3·e^(-1/2) ≈ 0.4, i.e. <= 22°) that leave flat stretches between them.
  constexpr double kSteepHeightMinM = 3.0, kSteepHeightMaxM = 4.0;
  constexpr double kSteepSigmaMinM = 2.0, kSteepSigmaMaxM = 2.5;
  constexpr int kGentleHillsMin = 5, kGentleHillsMax = 7;
  constexpr double kGentleHeightMinM = 0.5, kGentleHeightMaxM = 2.0;
  constexpr double kGentleSigmaMinM = 3.0, kGentleSigmaMaxM = 6.0;
  constexpr double kHollowProbability = 0.35;
  // Trees and rocks.
  constexpr int kTreesMin = 15, kTreesMax = 25;
  constexpr int kRocksMin = 10, kRocksMax = 15;
  constexpr double kTrunkRadiusMinM = 0.15, kTrunkRadiusMaxM = 0.3;
  constexpr double kCrownHeightMinM = 3.2, kCrownHeightMaxM = 5.0;  // Crown centre above foot.
  constexpr double kCrownRadiusMinM = 1.0, kCrownRadiusMaxM = 2.0;
  constexpr double kCrownClearanceM = 2.2;  // Crown bottom above the trunk's foot, > 2 m.
  constexpr double kRockRadiusMinM = 0.3, kRockRadiusMaxM = 0.8;
  constexpr double kRockFlatnessMin = 0.6, kRockFlatnessMax = 1.0;  // r_z / r_xy.
  constexpr double kMaxTreeSlopeTan = 0.364;                        // tan 20°.
  constexpr double kMaxRockSlopeTan = 0.466;                        // tan 25°.
  constexpr double kGapM = 0.5;  // Free space between neighbouring objects.
  constexpr int kMaxPlacementAttempts = 2000;

  std::mt19937 rng = MakeEngine(seed, kLayoutStream);
  UnevenTerrainLayout l{};
  l.size_m = kTerrainSizeM;
  const double n = kTerrainSizeM;

  l.hills.push_back({Uniform(rng, 0.3 * n, 0.7 * n), Uniform(rng, 0.3 * n, 0.7 * n),
                     Uniform(rng, kSteepHeightMinM, kSteepHeightMaxM),
                     Uniform(rng, kSteepSigmaMinM, kSteepSigmaMaxM)});
  const int n_gentle = UniformInt(rng, kGentleHillsMin, kGentleHillsMax);
  for (int i = 0; i < n_gentle; ++i) {
    UnevenTerrainLayout::Hill h{};
    h.x_m = Uniform(rng, 0.0, n);
    h.y_m = Uniform(rng, 0.0, n);
    h.height_m = Uniform(rng, kGentleHeightMinM, kGentleHeightMaxM);
    if (Uniform(rng, 0.0, 1.0) < kHollowProbability) h.height_m = -h.height_m;
    h.sigma_m = Uniform(rng, kGentleSigmaMinM, kGentleSigmaMaxM);
    l.hills.push_back(h);
  }
  // A long, low undulation (steepest slope A·2π/L ≈ 0.08, under 5°) so no area is perfectly
  // flat.
  l.wave_amplitude_m = 0.15;
  l.wave_length_m = 12.0;
  l.wave_phase_x_rad = Uniform(rng, 0.0, 2.0 * kPi);
  l.wave_phase_y_rad = Uniform(rng, 0.0, 2.0 * kPi);

  // Objects are placed by rejection sampling; a failed attempt still consumes its draws, so
  // the outcome depends on the seed only.
  const int n_trees = UniformInt(rng, kTreesMin, kTreesMax);
  for (int attempt = 0;
       attempt < kMaxPlacementAttempts && static_cast<int>(l.trees.size()) < n_trees; ++attempt) {
    UnevenTerrainLayout::Tree t{};
    t.crown_radius_m = Uniform(rng, kCrownRadiusMinM, kCrownRadiusMaxM);
    const double crown_height = Uniform(rng, kCrownHeightMinM, kCrownHeightMaxM);
    t.trunk_radius_m = Uniform(rng, kTrunkRadiusMinM, kTrunkRadiusMaxM);
    // Crowns stay inside the terrain's footprint.
    const double margin = t.crown_radius_m + kGapM;
    t.x_m = Uniform(rng, margin, n - margin);
    t.y_m = Uniform(rng, margin, n - margin);
    // Shrink the crown if needed so its bottom clears the trunk's foot by kCrownClearanceM.
    t.crown_radius_m = std::min(t.crown_radius_m, crown_height - kCrownClearanceM);
    if (t.crown_radius_m < kCrownRadiusMinM) continue;
    if (l.GradientAt(t.x_m, t.y_m).norm() > kMaxTreeSlopeTan) continue;
    const bool crowded = std::any_of(l.trees.begin(), l.trees.end(), [&](const auto& o) {
      return std::hypot(t.x_m - o.x_m, t.y_m - o.y_m) < t.crown_radius_m + o.crown_radius_m + kGapM;
    });
    if (crowded) continue;
    t.ground_z_m = l.HeightAt(t.x_m, t.y_m);
    t.crown_center_z_m = t.ground_z_m + crown_height;
    l.trees.push_back(t);
  }

  const int n_rocks = UniformInt(rng, kRocksMin, kRocksMax);
  for (int attempt = 0;
       attempt < kMaxPlacementAttempts && static_cast<int>(l.rocks.size()) < n_rocks; ++attempt) {
    UnevenTerrainLayout::Rock r{};
    r.radius_xy_m = Uniform(rng, kRockRadiusMinM, kRockRadiusMaxM);
    r.radius_z_m = r.radius_xy_m * Uniform(rng, kRockFlatnessMin, kRockFlatnessMax);
    const double margin = r.radius_xy_m + kGapM;
    r.x_m = Uniform(rng, margin, n - margin);
    r.y_m = Uniform(rng, margin, n - margin);
    if (l.GradientAt(r.x_m, r.y_m).norm() > kMaxRockSlopeTan) continue;
    const bool near_trunk = std::any_of(l.trees.begin(), l.trees.end(), [&](const auto& t) {
      return std::hypot(r.x_m - t.x_m, r.y_m - t.y_m) < r.radius_xy_m + t.trunk_radius_m + kGapM;
    });
    const bool near_rock = std::any_of(l.rocks.begin(), l.rocks.end(), [&](const auto& o) {
      return std::hypot(r.x_m - o.x_m, r.y_m - o.y_m) < r.radius_xy_m + o.radius_xy_m + kGapM;
    });
    if (near_trunk || near_rock) continue;
    r.center_z_m = l.HeightAt(r.x_m, r.y_m) - kRockBuriedFraction * r.radius_z_m;
    l.rocks.push_back(r);
  }
  return l;
}

PointCloud GenerateUnevenTerrain(std::uint32_t seed, double spacing_m) {
  if (!IsValidSpacing(spacing_m)) return {};
  const UnevenTerrainLayout l = GetUnevenTerrainLayout(seed);
  SurfaceSampler s(seed, spacing_m);

  const auto in_rock = [&l](const Vec3& p) {
    return std::any_of(l.rocks.begin(), l.rocks.end(), [&](const auto& r) {
      const double dx = (p.x() - r.x_m) / r.radius_xy_m;
      const double dy = (p.y() - r.y_m) / r.radius_xy_m;
      const double dz = (p.z() - r.center_z_m) / r.radius_z_m;
      return dx * dx + dy * dy + dz * dz < 1.0 - kEpsM;
    });
  };
  const auto in_tree = [&l](const Vec3& p) {
    return std::any_of(l.trees.begin(), l.trees.end(), [&](const auto& t) {
      const Vec3 crown(t.x_m, t.y_m, t.crown_center_z_m);
      const bool in_trunk = std::hypot(p.x() - t.x_m, p.y() - t.y_m) < t.trunk_radius_m - kEpsM &&
                            p.z() < t.crown_center_z_m;
      return in_trunk || (p - crown).norm() < t.crown_radius_m - kEpsM;
    });
  };
  const auto above_ground = [&l](const Vec3& p) {
    return p.z() >= l.HeightAt(p.x(), p.y()) - kEpsM;
  };
  const auto visible = [&](const Vec3& p) { return above_ground(p) && !in_rock(p) && !in_tree(p); };

  s.AddHeightField(
      0.0, l.size_m, 0.0, l.size_m, [&l](double x, double y) { return l.HeightAt(x, y); },
      [&](const Vec3& p) { return !in_rock(p) && !in_tree(p); });
  for (const auto& t : l.trees) {
    s.AddVerticalCylinder(t.x_m, t.y_m, t.trunk_radius_m, t.ground_z_m - kTrunkFootDepthM,
                          t.crown_center_z_m, visible);
    s.AddEllipsoid({t.x_m, t.y_m, t.crown_center_z_m}, t.crown_radius_m, t.crown_radius_m, visible);
  }
  for (const auto& r : l.rocks) {
    s.AddEllipsoid({r.x_m, r.y_m, r.center_z_m}, r.radius_xy_m, r.radius_z_m, visible);
  }
  return std::move(s).TakeCloud();
}

std::vector<std::string> SceneNames() {
  return {"stairs_ramp_room", "two_level_ramp", "uneven_terrain"};
}

Expected<PointCloud> GenerateScene(const std::string& name, std::uint32_t seed) {
  if (name == "stairs_ramp_room") return GenerateStairsRampRoom(seed);
  if (name == "two_level_ramp") return GenerateTwoLevelRamp(seed);
  if (name == "uneven_terrain") return GenerateUnevenTerrain(seed);
  std::string known;
  for (const std::string& n : SceneNames()) known += (known.empty() ? "" : ", ") + n;
  return Error{ErrorCode::kInvalidInput, "unknown scene \"" + name + "\"; known scenes: " + known};
}

}  // namespace strata
