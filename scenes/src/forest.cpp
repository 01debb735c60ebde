// uneven_forest: the uneven-terrain family at 40 m with more trees and rocks, and fallen logs.
#include <algorithm>
#include <array>
#include <cmath>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::kEpsM;
using internal::kPi;
using internal::Uniform;
using internal::UniformInt;
using internal::Vec2;
using internal::Vec3;

// The forest's layout engine: a stream of its own, so uneven_forest and uneven_terrain with the
// same seed are unrelated scenes.
constexpr std::uint32_t kForestLayoutStream = 3;
constexpr double kForestSizeM = 40.0;

internal::TerrainParams ForestParams() {
  internal::TerrainParams p;
  p.size_m = kForestSizeM;
  // Two steep hills (flanks >= 3/2.6·e^(-1/2) = 0.7, i.e. > 34°) among gentle hills and
  // hollows whose own flanks stay under 2/4.5·e^(-1/2) = 0.27 (15°), so most of the forest
  // floor is drivable and the steep ground forms islands a plan must go around.
  p.steep_hills = 2;
  p.steep_height_min_m = 3.0;
  p.steep_height_max_m = 4.5;
  p.steep_sigma_min_m = 2.0;
  p.steep_sigma_max_m = 2.6;
  p.gentle_hills_min = 8;
  p.gentle_hills_max = 11;
  p.gentle_height_min_m = 0.5;
  p.gentle_height_max_m = 2.0;
  p.gentle_sigma_min_m = 4.5;
  p.gentle_sigma_max_m = 7.0;
  p.trees_min = 28;
  p.trees_max = 38;
  p.rocks_min = 16;
  p.rocks_max = 22;
  return p;
}

double SegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

double SegmentDistance2d(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// Logs: drawn after the terrain's trees and rocks, from the same engine.
void PlaceLogs(std::mt19937& rng, UnevenForestLayout* forest) {
  constexpr int kLogsMin = 8, kLogsMax = 12;
  constexpr double kRadiusMinM = 0.15, kRadiusMaxM = 0.3;
  constexpr double kLengthMinM = 3.0, kLengthMaxM = 6.0;
  constexpr double kMaxSlopeTan = 0.268;  // tan 15°.
  // The ground under a log may bend away from its straight axis by this fraction of the radius.
  constexpr double kMaxBendFraction = 0.4;
  constexpr double kSunkFraction = 0.2;
  constexpr double kGapM = 0.5;
  constexpr int kSamples = 10;
  constexpr int kMaxPlacementAttempts = 2000;

  const UnevenTerrainLayout& t = forest->terrain;
  const double n = t.size_m;
  const int n_logs = UniformInt(rng, kLogsMin, kLogsMax);
  for (int attempt = 0;
       attempt < kMaxPlacementAttempts && static_cast<int>(forest->logs.size()) < n_logs;
       ++attempt) {
    const double radius = Uniform(rng, kRadiusMinM, kRadiusMaxM);
    const double length = Uniform(rng, kLengthMinM, kLengthMaxM);
    const double heading = Uniform(rng, 0.0, 2.0 * kPi);
    const double margin = 0.5 * length + 1.0;
    const Vec2 c(Uniform(rng, margin, n - margin), Uniform(rng, margin, n - margin));
    const Vec2 half = 0.5 * length * Vec2(std::cos(heading), std::sin(heading));
    const Vec2 a2 = c - half, b2 = c + half;
    const double za = t.HeightAt(a2.x(), a2.y()), zb = t.HeightAt(b2.x(), b2.y());
    bool fits = true;
    for (int k = 0; k <= kSamples && fits; ++k) {
      const double u = static_cast<double>(k) / kSamples;
      const Vec2 q = a2 + u * (b2 - a2);
      fits = t.GradientAt(q.x(), q.y()).norm() <= kMaxSlopeTan &&
             std::abs(t.HeightAt(q.x(), q.y()) - (za + u * (zb - za))) <= kMaxBendFraction * radius;
    }
    if (!fits) continue;
    const bool near_tree = std::any_of(t.trees.begin(), t.trees.end(), [&](const auto& tree) {
      return SegmentDistance2d({tree.x_m, tree.y_m}, a2, b2) < radius + tree.trunk_radius_m + kGapM;
    });
    const bool near_rock = std::any_of(t.rocks.begin(), t.rocks.end(), [&](const auto& r) {
      return SegmentDistance2d({r.x_m, r.y_m}, a2, b2) < radius + r.radius_xy_m + kGapM;
    });
    const bool near_log = std::any_of(forest->logs.begin(), forest->logs.end(), [&](const auto& o) {
      const Vec2 oa(o.a_m.x(), o.a_m.y()), ob(o.b_m.x(), o.b_m.y());
      double d = 1e9;
      for (int k = 0; k <= kSamples; ++k) {
        const double u = static_cast<double>(k) / kSamples;
        d = std::min({d, SegmentDistance2d(a2 + u * (b2 - a2), oa, ob),
                      SegmentDistance2d(oa + u * (ob - oa), a2, b2)});
      }
      return d < radius + o.radius_m + kGapM;
    });
    if (near_tree || near_rock || near_log) continue;
    const double lift = (1.0 - kSunkFraction) * radius;
    forest->logs.push_back(
        {Vec3(a2.x(), a2.y(), za + lift), Vec3(b2.x(), b2.y(), zb + lift), radius});
  }
}

// A query end near `anchor`: the nearest point of a 0.5 m lattice (within 8 m) on gentle ground
// well clear of every object and of the steep hills.
Vec3 GentleSpotNear(const UnevenForestLayout& f, const Vec2& anchor) {
  constexpr double kStepM = 0.5, kSearchM = 8.0, kClearM = 1.5, kEdgeM = 1.5;
  constexpr double kMaxSlopeTan = 0.14;  // tan 8°.
  const UnevenTerrainLayout& t = f.terrain;
  const auto suitable = [&](const Vec2& p) {
    if (p.x() < kEdgeM || p.y() < kEdgeM || p.x() > t.size_m - kEdgeM ||
        p.y() > t.size_m - kEdgeM) {
      return false;
    }
    for (int k = -1; k < 8; ++k) {
      const Vec2 q = k < 0 ? p : p + Vec2(std::cos(k * kPi / 4), std::sin(k * kPi / 4));
      if (t.GradientAt(q.x(), q.y()).norm() > kMaxSlopeTan) return false;
    }
    for (const auto& tree : t.trees) {
      if (std::hypot(p.x() - tree.x_m, p.y() - tree.y_m) < tree.trunk_radius_m + kClearM) {
        return false;
      }
    }
    for (const auto& r : t.rocks) {
      if (std::hypot(p.x() - r.x_m, p.y() - r.y_m) < r.radius_xy_m + kClearM) return false;
    }
    for (const auto& log : f.logs) {
      if (SegmentDistance2d(p, log.a_m.head<2>(), log.b_m.head<2>()) < log.radius_m + kClearM) {
        return false;
      }
    }
    // Off the steep hills' flat tops (islands above their steep flanks).
    for (const auto& h : t.hills) {
      if (h.sigma_m < 3.0 && std::hypot(p.x() - h.x_m, p.y() - h.y_m) < 4.0 * h.sigma_m) {
        return false;
      }
    }
    return true;
  };
  const int n = static_cast<int>(kSearchM / kStepM);
  Vec2 best = anchor;
  double best_d = 1e9;
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      const Vec2 p = anchor + kStepM * Vec2(i, j);
      const double d = (p - anchor).norm();
      if (d < best_d && suitable(p)) {
        best = p;
        best_d = d;
      }
    }
  }
  return {best.x(), best.y(), t.HeightAt(best.x(), best.y())};
}

}  // namespace

bool UnevenForestLayout::InsideLog(const Eigen::Vector3d& p_m) const {
  return std::any_of(logs.begin(), logs.end(), [&](const Log& log) {
    return SegmentDistance(p_m, log.a_m, log.b_m) < log.radius_m - kEpsM;
  });
}

UnevenForestLayout GetUnevenForestLayout(std::uint32_t seed) {
  std::mt19937 rng = internal::MakeEngine(seed, kForestLayoutStream);
  UnevenForestLayout f;
  f.terrain = internal::BuildTerrainLayout(rng, ForestParams());
  PlaceLogs(rng, &f);
  f.assessment_resolution_m = 0.2;
  const double n = f.terrain.size_m;
  const std::array<std::pair<const char*, std::array<Vec2, 2>>, 3> anchors = {{
      {"southwest_to_northeast", {Vec2(3.0, 3.0), Vec2(n - 3.0, n - 3.0)}},
      {"northwest_to_southeast", {Vec2(3.0, n - 3.0), Vec2(n - 3.0, 3.0)}},
      {"south_to_north", {Vec2(0.5 * n, 3.0), Vec2(0.5 * n, n - 3.0)}},
  }};
  for (const auto& [name, ends] : anchors) {
    f.queries.push_back(
        {name, GentleSpotNear(f, ends[0]), GentleSpotNear(f, ends[1]), "differential"});
  }
  return f;
}

PointCloud GenerateUnevenForest(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const UnevenForestLayout f = GetUnevenForestLayout(seed);
  internal::SurfaceSampler s(seed, spacing_m);
  const auto in_log = [&f](const Vec3& p) { return f.InsideLog(p); };
  internal::SampleTerrain(s, f.terrain, in_log);
  const UnevenTerrainLayout& t = f.terrain;
  const auto visible = [&](const Vec3& p) {
    return p.z() >= t.HeightAt(p.x(), p.y()) - kEpsM && !internal::InsideRock(t, p) &&
           !internal::InsideTree(t, p) && !f.InsideLog(p);
  };
  for (const auto& log : f.logs) {
    s.AddCylinder(log.a_m, log.b_m, log.radius_m, visible);
    // The discs lie on the log's boundary, so they are tested without the log itself.
    const auto visible_disc = [&](const Vec3& p) {
      return p.z() >= t.HeightAt(p.x(), p.y()) - kEpsM && !internal::InsideRock(t, p) &&
             !internal::InsideTree(t, p);
    };
    const Vec3 axis = log.b_m - log.a_m;
    s.AddDisc(log.a_m, axis, log.radius_m, visible_disc);
    s.AddDisc(log.b_m, axis, log.radius_m, visible_disc);
  }
  return std::move(s).TakeCloud();
}

}  // namespace strata
