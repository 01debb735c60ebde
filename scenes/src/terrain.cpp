// The uneven-terrain family: the height field, its trees and rocks, and the uneven_terrain
// scene. uneven_forest (forest.cpp) builds on the same layout.
#include <algorithm>
#include <cmath>

#include "scenes_internal.hpp"

namespace strata {
namespace internal {
namespace {

// Below the ground at a trunk's foot the trunk is started this deep, so it meets the terrain on
// the downhill side as well; the part below ground is clipped.
constexpr double kTrunkFootDepthM = 0.5;
// Fraction of a rock's vertical radius that is buried, so rocks sit in the ground, not on it.
constexpr double kRockBuriedFraction = 0.2;

}  // namespace

UnevenTerrainLayout BuildTerrainLayout(std::mt19937& rng, const TerrainParams& p) {
  // Trees and rocks.
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

  UnevenTerrainLayout l{};
  l.size_m = p.size_m;
  const double n = p.size_m;

  for (int i = 0; i < p.steep_hills; ++i) {
    l.hills.push_back({Uniform(rng, 0.3 * n, 0.7 * n), Uniform(rng, 0.3 * n, 0.7 * n),
                       Uniform(rng, p.steep_height_min_m, p.steep_height_max_m),
                       Uniform(rng, p.steep_sigma_min_m, p.steep_sigma_max_m)});
  }
  const int n_gentle = UniformInt(rng, p.gentle_hills_min, p.gentle_hills_max);
  for (int i = 0; i < n_gentle; ++i) {
    UnevenTerrainLayout::Hill h{};
    h.x_m = Uniform(rng, 0.0, n);
    h.y_m = Uniform(rng, 0.0, n);
    h.height_m = Uniform(rng, p.gentle_height_min_m, p.gentle_height_max_m);
    if (Uniform(rng, 0.0, 1.0) < p.hollow_probability) h.height_m = -h.height_m;
    h.sigma_m = Uniform(rng, p.gentle_sigma_min_m, p.gentle_sigma_max_m);
    l.hills.push_back(h);
  }
  l.wave_amplitude_m = p.wave_amplitude_m;
  l.wave_length_m = p.wave_length_m;
  l.wave_phase_x_rad = Uniform(rng, 0.0, 2.0 * kPi);
  l.wave_phase_y_rad = Uniform(rng, 0.0, 2.0 * kPi);

  // Objects are placed by rejection sampling; a failed attempt still consumes its draws, so
  // the outcome depends on the seed only.
  const int n_trees = UniformInt(rng, p.trees_min, p.trees_max);
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

  const int n_rocks = UniformInt(rng, p.rocks_min, p.rocks_max);
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

bool InsideRock(const UnevenTerrainLayout& l, const Vec3& p) {
  return std::any_of(l.rocks.begin(), l.rocks.end(), [&](const auto& r) {
    const double dx = (p.x() - r.x_m) / r.radius_xy_m;
    const double dy = (p.y() - r.y_m) / r.radius_xy_m;
    const double dz = (p.z() - r.center_z_m) / r.radius_z_m;
    return dx * dx + dy * dy + dz * dz < 1.0 - kEpsM;
  });
}

bool InsideTree(const UnevenTerrainLayout& l, const Vec3& p) {
  return std::any_of(l.trees.begin(), l.trees.end(), [&](const auto& t) {
    const Vec3 crown(t.x_m, t.y_m, t.crown_center_z_m);
    const bool in_trunk = std::hypot(p.x() - t.x_m, p.y() - t.y_m) < t.trunk_radius_m - kEpsM &&
                          p.z() < t.crown_center_z_m;
    return in_trunk || (p - crown).norm() < t.crown_radius_m - kEpsM;
  });
}

void SampleTerrain(SurfaceSampler& s, const UnevenTerrainLayout& l, const KeepFn& in_extra_solid) {
  const auto hidden = [&](const Vec3& p) {
    return InsideRock(l, p) || InsideTree(l, p) || (in_extra_solid && in_extra_solid(p));
  };
  const auto visible = [&](const Vec3& p) {
    return p.z() >= l.HeightAt(p.x(), p.y()) - kEpsM && !hidden(p);
  };
  s.AddHeightField(
      0.0, l.size_m, 0.0, l.size_m, [&l](double x, double y) { return l.HeightAt(x, y); },
      [&](const Vec3& p) { return !hidden(p); });
  for (const auto& t : l.trees) {
    s.AddVerticalCylinder(t.x_m, t.y_m, t.trunk_radius_m, t.ground_z_m - kTrunkFootDepthM,
                          t.crown_center_z_m, visible);
    s.AddEllipsoid({t.x_m, t.y_m, t.crown_center_z_m}, t.crown_radius_m, t.crown_radius_m, visible);
  }
  for (const auto& r : l.rocks) {
    s.AddEllipsoid({r.x_m, r.y_m, r.center_z_m}, r.radius_xy_m, r.radius_z_m, visible);
  }
}

}  // namespace internal

using internal::kPi;
using internal::Vec2;

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
  // The defaults of TerrainParams are this scene's: one steep hill so every seed has slopes
  // beyond 30° (a Gaussian's steepest slope is height/sigma·e^(-1/2), here >= 0.73, i.e.
  // >= 36°), then gentler hills and hollows (<= 2/3·e^(-1/2) ≈ 0.4, i.e. <= 22°) that leave
  // flat stretches between them, and a long, low undulation (steepest slope A·2π/L ≈ 0.08,
  // under 5°) so no area is perfectly flat.
  std::mt19937 rng = internal::MakeEngine(seed, internal::kLayoutStream);
  return internal::BuildTerrainLayout(rng, internal::TerrainParams{});
}

PointCloud GenerateUnevenTerrain(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const UnevenTerrainLayout l = GetUnevenTerrainLayout(seed);
  internal::SurfaceSampler s(seed, spacing_m);
  internal::SampleTerrain(s, l, {});
  return std::move(s).TakeCloud();
}

}  // namespace strata
