// outdoor_site: rolling hills, steep heaps, box obstacles and a compound (a bridge over a road,
// a two-storey building) on a square site from 40 m to 1 km across.
//
// Written for speed: the 1 km site at 0.2 m is about 27 million points. The ground, nearly all
// of them, is sampled by one loop that evaluates the hills column by column (the B-splines
// contracted along x once per column, a few multiply-adds per point) and skips the ground
// under footprints by sweeping each column's sorted footprint chords, never by testing every
// obstacle. The cloud is reserved for an upper bound counted before sampling, so it is never
// reallocated.
#include "strata/scenes/outdoor_site.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "scenes_internal.hpp"

namespace strata {
namespace internal {
namespace {

// The site's layout engine: a stream of its own, unrelated to the other scenes' layouts.
constexpr std::uint32_t kSiteLayoutStream = 4;

// Hills: two octaves of bicubic B-splines, knots every size/4 and every size/16, the fine one
// at 0.3 of the coarse one's amplitude; the same landscape scaled with the site, so the relief
// grows with the size while the slopes do not.
constexpr std::array<int, 2> kOctaveCells = {4, 16};
constexpr std::array<double, 2> kOctaveAmplitude = {1.0, 0.3};
constexpr double kReliefPerSize = 0.03;  // 12 m at 400 m.
constexpr double kMaxHillSlopeDeg = 12.0;
// The pad joins the hills over max(15 m, 5% of the size).
constexpr double kMinBlendM = 15.0, kBlendPerSize = 0.05;
// Hill slopes are measured on a grid this many times finer than the finest feature.
constexpr double kSlopeSamplesPerFeature = 8.0;

// The compound, in its own coordinates (from its south-west corner; heights above the pad).
constexpr double kCompoundXM = 40.0, kCompoundYM = 30.0;
constexpr double kPadApronM = 2.0;  // Level ground around the compound.
constexpr double kRailingM = 1.0;
constexpr double kRampSlopeDeg = 12.0;
constexpr double kDeckZM = 2.8, kDeckThicknessM = 0.3;
constexpr double kDeckYMinM = 4.0, kDeckWidthM = 5.0;
constexpr double kSpanM = 6.0, kRoadWidthM = 5.0;
constexpr double kBuildingXMinM = 7.0, kBuildingYMinM = 14.0;
constexpr double kBuildingXM = 26.0, kBuildingYM = 14.0;
constexpr double kUpperFloorZM = 3.0, kRoofZM = 6.0, kSlabM = 0.25;
constexpr double kBuildingRampToeM = 3.0;  // From the west wall.
constexpr double kBuildingRampWidthM = 3.5;
constexpr double kDoorTopM = 2.4, kSouthDoorWidthM = 3.0;
constexpr double kPartitionFromWestM = 20.0;
constexpr double kPartitionDoorWidthM = 2.5, kPartitionDoorTopM = 2.2;

// Heaps: the deliberately steep ground (flanks 1.717·height/radius: 29.6° to 35.8°).
constexpr double kHeapAreaM2 = 140.0 * 140.0;
constexpr double kHeapRadiusMinM = 8.0, kHeapRadiusMaxM = 12.0;
constexpr double kHeapSteepnessMin = 0.33, kHeapSteepnessMax = 0.42;  // Height / radius.
constexpr double kHeapGapM = 5.0;                                     // Between heaps.
constexpr double kHeapPadGapM = 3.0;                                  // Between a heap and the pad.
constexpr int kHeapAttempts = 200;  // Per heap; a heap that finds no room is left out.

// Obstacles: at most one per cell, kept kObstacleMarginM inside it, so obstacles stand at
// least twice that apart and a robot always finds a way between them.
constexpr double kObstacleCellM = 16.0;
constexpr double kObstacleProbability = 0.4;
constexpr double kObstacleMarginM = 1.5;
constexpr double kObstaclePadGapM = 2.0;
constexpr double kObstacleHeapGapM = 1.0;
constexpr double kObstacleSunkM = 0.3;  // Below the lowest ground under it.

// The ends of across_the_hills lie this far from the site's edges (at least 3 m) and keep
// obstacles and heaps this far away.
constexpr double kQueryEndFraction = 0.05, kQueryEndMinM = 3.0;
constexpr double kKeepClearM = 6.0;

// Uniform cubic B-spline weights of the four coefficients of a knot interval at u in [0, 1].
std::array<double, 4> BSplineWeights(double u) {
  const double u2 = u * u, u3 = u2 * u, v = 1.0 - u;
  return {v * v * v / 6.0, (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
          (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0, u3 / 6.0};
}

// The knot interval holding t (in knots) and the position in it, clamped to the octave.
std::pair<int, double> KnotInterval(double t, int cells) {
  const int i = std::clamp(static_cast<int>(std::floor(t)), 0, cells - 1);
  return {i, t - i};
}

double SmoothStep(double t) { return t * t * (3.0 - 2.0 * t); }

// The ground of one column x = const, for evaluation along y: the octaves contracted along x,
// the distance from the pad along x and the heaps that reach x. GroundZAt and the sampler use
// it alike, so both give the same heights to the last bit.
class GroundColumn {
 public:
  explicit GroundColumn(const OutdoorSiteLayout& l) : l_(l) {
    for (std::size_t k = 0; k < l.octaves.size(); ++k) {
      rows_[k].resize(static_cast<std::size_t>(l.octaves[k].cells) + 3);
    }
  }

  double x() const { return x_; }

  void MoveTo(double x) {
    x_ = x;
    for (std::size_t k = 0; k < l_.octaves.size(); ++k) {
      const OutdoorSiteLayout::Octave& o = l_.octaves[k];
      const auto [i, u] = KnotInterval(x / o.knot_spacing_m, o.cells);
      const std::array<double, 4> w = BSplineWeights(u);
      const std::size_t n = rows_[k].size();
      for (std::size_t q = 0; q < n; ++q) {
        double sum = 0.0;
        for (std::size_t a = 0; a < 4; ++a) {
          sum += w[a] * o.coefficients[(static_cast<std::size_t>(i) + a) * n + q];
        }
        rows_[k][q] = sum;
      }
    }
    pad_dx_ = std::max({l_.pad_x_min_m - x, 0.0, x - l_.pad_x_max_m});
    heaps_.clear();
    for (const OutdoorSiteLayout::Heap& h : l_.heaps) {
      if (std::abs(x - h.x_m) < h.radius_m) heaps_.push_back(&h);
    }
  }

  double HeightAt(double y) const {
    double z = 0.0;
    const double dy = std::max({l_.pad_y_min_m - y, 0.0, y - l_.pad_y_max_m});
    const double d2 = pad_dx_ * pad_dx_ + dy * dy;
    if (d2 > 0.0) {
      const double blend = l_.blend_m;
      const double w = d2 >= blend * blend ? 0.0 : SmoothStep(1.0 - std::sqrt(d2) / blend);
      z = l_.hill_scale * (1.0 - w) * (HillsAt(y) - l_.hill_offset);
    }
    for (const OutdoorSiteLayout::Heap* h : heaps_) {
      const double hx = x_ - h->x_m, hy = y - h->y_m;
      const double s = 1.0 - (hx * hx + hy * hy) / (h->radius_m * h->radius_m);
      if (s > 0.0) z += h->height_m * s * s * s;
    }
    return z;
  }

  // The octaves' sum at (x, y), unscaled.
  double HillsAt(double y) const {
    double sum = 0.0;
    for (std::size_t k = 0; k < l_.octaves.size(); ++k) {
      const OutdoorSiteLayout::Octave& o = l_.octaves[k];
      const auto [j, v] = KnotInterval(y / o.knot_spacing_m, o.cells);
      const std::array<double, 4> w = BSplineWeights(v);
      const double* row = rows_[k].data() + j;
      sum += w[0] * row[0] + w[1] * row[1] + w[2] * row[2] + w[3] * row[3];
    }
    return sum;
  }

 private:
  const OutdoorSiteLayout& l_;
  double x_ = 0.0;
  std::array<std::vector<double>, kOctaveCells.size()> rows_;
  double pad_dx_ = 0.0;
  std::vector<const OutdoorSiteLayout::Heap*> heaps_;
};

double RectDistance(double x, double y, double x0, double x1, double y0, double y1) {
  const double dx = std::max({x0 - x, 0.0, x - x1});
  const double dy = std::max({y0 - y, 0.0, y - y1});
  return std::hypot(dx, dy);
}

bool RectsOverlap(const Vec2& a_lo, const Vec2& a_hi, const Vec2& b_lo, const Vec2& b_hi) {
  return a_lo.x() < b_hi.x() && b_lo.x() < a_hi.x() && a_lo.y() < b_hi.y() && b_lo.y() < a_hi.y();
}

// The hills: octaves drawn from the layout engine, flattened around the pad's centre, then
// scaled to the target relief unless that would make them steeper than kMaxHillSlopeDeg.
void DrawHills(std::mt19937& rng, OutdoorSiteLayout* l) {
  const double size = l->size_m;
  for (std::size_t k = 0; k < kOctaveCells.size(); ++k) {
    OutdoorSiteLayout::Octave o;
    o.cells = kOctaveCells[k];
    o.knot_spacing_m = size / o.cells;
    const auto n = static_cast<std::size_t>(o.cells) + 3;
    o.coefficients.resize(n * n);
    for (double& c : o.coefficients) c = Uniform(rng, -1.0, 1.0) * kOctaveAmplitude[k];
    // The pad's centre is the middle knot of every octave. Its 3 × 3 coefficients made equal,
    // the hills have no slope and no curvature there, so the pad cuts little into them.
    const auto mid = static_cast<std::size_t>(o.cells / 2) + 1;
    const double centre = o.coefficients[mid * n + mid];
    for (std::size_t a = mid - 1; a <= mid + 1; ++a) {
      for (std::size_t b = mid - 1; b <= mid + 1; ++b) o.coefficients[a * n + b] = centre;
    }
    l->octaves.push_back(std::move(o));
  }
  l->hill_scale = 1.0;
  l->hill_offset = 0.0;
  {
    GroundColumn centre(*l);
    centre.MoveTo(0.5 * size);
    l->hill_offset = centre.HillsAt(0.5 * size);
  }
  // Relief and steepest slope of the unscaled hills (blend included, heaps not drawn yet),
  // from finite differences on a grid fine enough for the finest octave and the blend.
  const double feature = std::min(size / kOctaveCells.back(), l->blend_m);
  const int n = static_cast<int>(std::ceil(size * kSlopeSamplesPerFeature / feature));
  const double step = size / n;
  GroundColumn column(*l);
  std::vector<double> previous(static_cast<std::size_t>(n + 1)), current(previous.size());
  double lo = 0.0, hi = 0.0, max_slope = 0.0;
  for (int i = 0; i <= n; ++i) {
    column.MoveTo(i * step);
    for (int j = 0; j <= n; ++j) {
      const double z = column.HeightAt(j * step);
      current[static_cast<std::size_t>(j)] = z;
      lo = std::min(lo, z);
      hi = std::max(hi, z);
      if (i > 0 && j > 0) {
        const double gx = (z - previous[static_cast<std::size_t>(j)]) / step;
        const double gy = (z - current[static_cast<std::size_t>(j - 1)]) / step;
        max_slope = std::max(max_slope, std::hypot(gx, gy));
      }
    }
    std::swap(previous, current);
  }
  const double target = kReliefPerSize * size;
  double scale = hi > lo ? target / (hi - lo) : 0.0;
  if (max_slope > 0.0) scale = std::min(scale, std::tan(kMaxHillSlopeDeg * kDegToRad) / max_slope);
  l->hill_scale = scale;
  l->relief_m = scale * (hi - lo);
}

void PlaceHeaps(std::mt19937& rng, const std::array<Vec2, 2>& query_ends, OutdoorSiteLayout* l) {
  const double size = l->size_m;
  const int wanted = std::max(1, static_cast<int>(std::lround(size * size / kHeapAreaM2)));
  for (int h = 0; h < wanted; ++h) {
    for (int attempt = 0; attempt < kHeapAttempts; ++attempt) {
      OutdoorSiteLayout::Heap heap{};
      heap.radius_m = Uniform(rng, kHeapRadiusMinM, kHeapRadiusMaxM);
      heap.height_m = heap.radius_m * Uniform(rng, kHeapSteepnessMin, kHeapSteepnessMax);
      heap.x_m = Uniform(rng, 0.0, size);
      heap.y_m = Uniform(rng, 0.0, size);
      const Vec2 c(heap.x_m, heap.y_m);
      bool fits = RectDistance(c.x(), c.y(), l->pad_x_min_m, l->pad_x_max_m, l->pad_y_min_m,
                               l->pad_y_max_m) >= heap.radius_m + kHeapPadGapM;
      for (const Vec2& end : query_ends) {
        fits = fits && (c - end).norm() >= heap.radius_m + kKeepClearM;
      }
      for (const OutdoorSiteLayout::Heap& o : l->heaps) {
        fits = fits && (c - Vec2(o.x_m, o.y_m)).norm() >= heap.radius_m + o.radius_m + kHeapGapM;
      }
      if (!fits) continue;
      l->heaps.push_back(heap);
      break;
    }
  }
}

void PlaceObstacles(std::mt19937& rng, const std::array<Vec2, 2>& query_ends,
                    OutdoorSiteLayout* l) {
  using Kind = OutdoorSiteLayout::Obstacle::Kind;
  const double size = l->size_m;
  const int cells = static_cast<int>(std::floor(size / kObstacleCellM));
  const Vec2 pad_lo(l->pad_x_min_m - kObstaclePadGapM, l->pad_y_min_m - kObstaclePadGapM);
  const Vec2 pad_hi(l->pad_x_max_m + kObstaclePadGapM, l->pad_y_max_m + kObstaclePadGapM);
  GroundColumn column(*l);
  for (int cx = 0; cx < cells; ++cx) {
    for (int cy = 0; cy < cells; ++cy) {
      // Every cell draws the same numbers, used or not, so a cell's obstacle does not depend
      // on what happened in the cells before it.
      const double present = Uniform(rng, 0.0, 1.0);
      const double kind_draw = Uniform(rng, 0.0, 1.0);
      const double a = Uniform(rng, 0.0, 1.0), b = Uniform(rng, 0.0, 1.0);
      const double c = Uniform(rng, 0.0, 1.0);
      const bool along_x = Uniform(rng, 0.0, 1.0) < 0.5;
      const double fx = Uniform(rng, 0.0, 1.0), fy = Uniform(rng, 0.0, 1.0);
      if (present >= kObstacleProbability) continue;
      Kind kind;
      double length, width, height;
      if (kind_draw < 0.45) {
        kind = Kind::kContainer;  // ISO 20 ft: 6.06 × 2.44 × 2.59 m; one in five stacked.
        length = 6.06;
        width = 2.44;
        height = a < 0.2 ? 2 * 2.59 : 2.59;
      } else if (kind_draw < 0.75) {
        kind = Kind::kShed;
        length = 2.5 + 2.5 * a;
        width = 2.5 + 1.5 * b;
        height = 2.2 + 0.8 * c;
      } else {
        kind = Kind::kWall;
        length = 5.0 + 7.0 * a;
        width = 0.3;
        height = 1.2 + 1.2 * c;
      }
      const double ex = along_x ? length : width, ey = along_x ? width : length;
      const double room_x = kObstacleCellM - 2 * kObstacleMarginM - ex;
      const double room_y = kObstacleCellM - 2 * kObstacleMarginM - ey;
      const Vec2 lo(cx * kObstacleCellM + kObstacleMarginM + fx * room_x,
                    cy * kObstacleCellM + kObstacleMarginM + fy * room_y);
      const Vec2 hi = lo + Vec2(ex, ey);
      if (RectsOverlap(lo, hi, pad_lo, pad_hi)) continue;
      const bool near_end = std::any_of(query_ends.begin(), query_ends.end(), [&](const Vec2& e) {
        return RectDistance(e.x(), e.y(), lo.x(), hi.x(), lo.y(), hi.y()) < kKeepClearM;
      });
      const bool on_heap = std::any_of(l->heaps.begin(), l->heaps.end(), [&](const auto& h) {
        return RectDistance(h.x_m, h.y_m, lo.x(), hi.x(), lo.y(), hi.y()) <
               h.radius_m + kObstacleHeapGapM;
      });
      if (near_end || on_heap) continue;
      double z_min = 1e9, z_max = -1e9;
      for (const double x : {lo.x(), 0.5 * (lo.x() + hi.x()), hi.x()}) {
        column.MoveTo(x);
        for (const double y : {lo.y(), 0.5 * (lo.y() + hi.y()), hi.y()}) {
          const double z = column.HeightAt(y);
          z_min = std::min(z_min, z);
          z_max = std::max(z_max, z);
        }
      }
      l->obstacles.push_back({kind, Vec3(lo.x(), lo.y(), z_min - kObstacleSunkM),
                              Vec3(hi.x(), hi.y(), z_max + height)});
    }
  }
}

// An axis-aligned footprint that hides the ground under it.
struct Footprint {
  double x_min, x_max, y_min, y_max;
};

std::vector<Footprint> Footprints(const OutdoorSiteLayout& l) {
  std::vector<Footprint> f;
  f.reserve(l.obstacles.size() + 3);
  for (const auto& o : l.obstacles) f.push_back({o.lo_m.x(), o.hi_m.x(), o.lo_m.y(), o.hi_m.y()});
  for (const SceneRamp& r : l.bridge_ramps)
    f.push_back({r.x_min_m, r.x_max_m, r.y_min_m, r.y_max_m});
  const SceneRamp& r = l.building_ramp;
  f.push_back({r.x_min_m, r.x_max_m, r.y_min_m, r.y_max_m});
  std::sort(f.begin(), f.end(),
            [](const Footprint& a, const Footprint& b) { return a.x_min < b.x_min; });
  return f;
}

// The ground: a lattice over the whole site at about the spacing (fitted to its edges), minus
// the points strictly inside a footprint. Footprints do not overlap, so in each column the
// chords of those that straddle it, sorted along y, are passed once.
void SampleGround(SurfaceSampler& s, const OutdoorSiteLayout& l) {
  const std::vector<Footprint> footprints = Footprints(l);
  const int n = Intervals(l.size_m, s.spacing_m());
  GroundColumn column(l);
  std::vector<const Footprint*> active;
  std::vector<std::pair<double, double>> chords;
  std::size_t next = 0;
  for (int i = 0; i <= n; ++i) {
    const double x = l.size_m * i / n;
    column.MoveTo(x);
    while (next < footprints.size() && footprints[next].x_min + kEpsM < x) {
      active.push_back(&footprints[next++]);
    }
    std::erase_if(active, [x](const Footprint* f) { return f->x_max - kEpsM <= x; });
    chords.clear();
    for (const Footprint* f : active) chords.emplace_back(f->y_min, f->y_max);
    std::sort(chords.begin(), chords.end());
    std::size_t k = 0;
    for (int j = 0; j <= n; ++j) {
      const double y = l.size_m * j / n;
      while (k < chords.size() && chords[k].second - kEpsM <= y) ++k;
      if (k < chords.size() && y > chords[k].first + kEpsM) continue;
      s.AddPoint({x, y, column.HeightAt(y)});
    }
  }
}

// Boxes: top and the sides above the ground.
void SampleObstacles(SurfaceSampler& s, const OutdoorSiteLayout& l) {
  GroundColumn column(l);
  const KeepFn above_ground = [&column](const Vec3& p) {
    if (p.x() != column.x()) column.MoveTo(p.x());
    return p.z() >= column.HeightAt(p.y()) - kEpsM;
  };
  column.MoveTo(0.0);
  for (const auto& o : l.obstacles) {
    s.AddBoxSurfaces(o.lo_m, o.hi_m, /*with_bottom=*/false, above_ground);
  }
}

void SampleBridge(SurfaceSampler& s, const OutdoorSiteLayout& l) {
  const double rail = l.railing_height_m;
  const double under = l.bridge_deck_underside_z_m, deck = l.bridge_deck_z_m;
  // Ramps: solid embankments whose sides carry the railing, and the abutment under each
  // ramp's top end.
  for (const SceneRamp& r : l.bridge_ramps) {
    AddSolidRamp(s, r, /*with_sides=*/true, rail, /*back_bottom_z_m=*/r.z_high_m);
    const double x = r.uphill_dir.x() > 0 ? r.x_max_m : r.x_min_m;
    s.AddVerticalRect({x, r.y_min_m}, {x, r.y_max_m}, l.ground_floor_z_m, under);
  }
  // The span: top, underside, and the slab's edge plus its railing as one sheet on each side.
  const double x0 = l.bridge_span_x_min_m, x1 = l.bridge_span_x_max_m;
  s.AddHorizontalRect(x0, x1, l.bridge_y_min_m, l.bridge_y_max_m, deck);
  s.AddHorizontalRect(x0, x1, l.bridge_y_min_m, l.bridge_y_max_m, under);
  for (const double y : {l.bridge_y_min_m, l.bridge_y_max_m}) {
    s.AddVerticalRect({x0, y}, {x1, y}, under, deck + rail);
  }
}

void SampleBuilding(SurfaceSampler& s, const OutdoorSiteLayout& l) {
  const double x0 = l.building_x_min_m, x1 = l.building_x_max_m;
  const double y0 = l.building_y_min_m, y1 = l.building_y_max_m;
  const double floor = l.ground_floor_z_m, upper = l.upper_floor_z_m;
  const double upper_under = l.upper_floor_underside_z_m;
  const double roof = l.roof_z_m, roof_under = l.roof_underside_z_m;
  const SceneRamp& ramp = l.building_ramp;
  const double rail = l.railing_height_m;
  const auto in_slab = [&](double z) {
    return StrictlyInside(z, upper_under, upper) || StrictlyInside(z, roof_under, roof);
  };
  const auto in_door = [](const OutdoorSiteLayout::Door& d, double along, double z) {
    return StrictlyInside(along, d.from_m, d.to_m) && z < d.top_z_m - kEpsM;
  };

  // Outer walls from the ground to the roof, open at the doors; hidden inside the slabs.
  s.AddVerticalRect({x0, y0}, {x1, y0}, floor, roof, [&](const Vec3& p) {
    return !in_slab(p.z()) && !in_door(l.south_door, p.x(), p.z());
  });
  s.AddVerticalRect({x1, y0}, {x1, y1}, floor, roof,
                    [&](const Vec3& p) { return !in_slab(p.z()); });
  s.AddVerticalRect({x1, y1}, {x0, y1}, floor, roof,
                    [&](const Vec3& p) { return !in_slab(p.z()); });
  s.AddVerticalRect({x0, y1}, {x0, y0}, floor, roof, [&](const Vec3& p) {
    return !in_slab(p.z()) && !in_door(l.west_door, p.y(), p.z());
  });

  // Upper floor (both faces, open over the ramp) and roof (both faces).
  const KeepFn outside_opening = [&l](const Vec3& p) { return l.HasUpperFloor(p.x(), p.y()); };
  s.AddHorizontalRect(x0, x1, y0, y1, upper, outside_opening);
  s.AddHorizontalRect(x0, x1, y0, y1, upper_under, outside_opening);
  s.AddHorizontalRect(x0, x1, y0, y1, roof);
  s.AddHorizontalRect(x0, x1, y0, y1, roof_under);

  // The ramp: a solid wedge whose sides carry a railing, its back face under the upper floor.
  AddSolidRamp(s, ramp, /*with_sides=*/true, rail, /*back_bottom_z_m=*/floor, [&](const Vec3& p) {
    return !(std::abs(p.x() - ramp.x_max_m) < kEpsM && StrictlyInside(p.z(), upper_under, upper));
  });
  // The opening's edge and railing on the upper floor: along both sides above the ramp's own
  // railing, and across its low end.
  for (const double y : {ramp.y_min_m, ramp.y_max_m}) {
    s.AddVerticalRect(
        {ramp.x_min_m, y}, {ramp.x_max_m, y}, upper_under, upper + rail,
        [&](const Vec3& p) { return p.z() > ramp.TopZAt(p.x(), p.y()) + rail + kEpsM; });
  }
  s.AddVerticalRect({ramp.x_min_m, ramp.y_min_m}, {ramp.x_min_m, ramp.y_max_m}, upper_under,
                    upper + rail);

  // The upper storey's partition and its door.
  s.AddVerticalRect({l.partition_x_m, y0}, {l.partition_x_m, y1}, upper, roof_under,
                    [&](const Vec3& p) { return !in_door(l.partition_door, p.y(), p.z()); });
}

void SampleStructures(SurfaceSampler& s, const OutdoorSiteLayout& l) {
  SampleObstacles(s, l);
  SampleBridge(s, l);
  SampleBuilding(s, l);
}

// Every lattice point the sampling offers, kept or not: the ground's whole lattice and the
// structures' faces, counted column by column without visiting their points.
std::size_t PointBound(const OutdoorSiteLayout& l, double spacing_m) {
  const auto ground = static_cast<std::size_t>(Intervals(l.size_m, spacing_m)) + 1;
  SurfaceSampler counter = SurfaceSampler::Counter(spacing_m);
  SampleStructures(counter, l);
  return ground * ground + counter.counted();
}

OutdoorSiteLayout BuildLayout(std::uint32_t seed, double size_m) {
  OutdoorSiteLayout l{};
  const double size = std::clamp(size_m, kOutdoorSiteMinSizeM, kOutdoorSiteMaxSizeM);
  l.size_m = size;

  // The compound at the centre, on its pad.
  const double cx = 0.5 * (size - kCompoundXM), cy = 0.5 * (size - kCompoundYM);
  l.compound_x_min_m = cx;
  l.compound_y_min_m = cy;
  l.pad_x_min_m = cx - kPadApronM;
  l.pad_x_max_m = cx + kCompoundXM + kPadApronM;
  l.pad_y_min_m = cy - kPadApronM;
  l.pad_y_max_m = cy + kCompoundYM + kPadApronM;
  l.blend_m = std::max(kMinBlendM, kBlendPerSize * size);
  l.railing_height_m = kRailingM;
  l.ground_floor_z_m = 0.0;

  const double tan_slope = std::tan(kRampSlopeDeg * kDegToRad);
  l.bridge_deck_z_m = kDeckZM;
  l.bridge_deck_underside_z_m = kDeckZM - kDeckThicknessM;
  l.bridge_span_x_min_m = cx + 0.5 * (kCompoundXM - kSpanM);
  l.bridge_span_x_max_m = cx + 0.5 * (kCompoundXM + kSpanM);
  l.bridge_y_min_m = cy + kDeckYMinM;
  l.bridge_y_max_m = cy + kDeckYMinM + kDeckWidthM;
  const double deck_run = kDeckZM / tan_slope;
  l.bridge_ramps = {{l.bridge_span_x_min_m - deck_run, l.bridge_span_x_min_m, l.bridge_y_min_m,
                     l.bridge_y_max_m, 0.0, kDeckZM, Vec2::UnitX()},
                    {l.bridge_span_x_max_m, l.bridge_span_x_max_m + deck_run, l.bridge_y_min_m,
                     l.bridge_y_max_m, 0.0, kDeckZM, -Vec2::UnitX()}};
  l.road_x_min_m = cx + 0.5 * (kCompoundXM - kRoadWidthM);
  l.road_x_max_m = cx + 0.5 * (kCompoundXM + kRoadWidthM);
  l.road_y_min_m = cy;
  l.road_y_max_m = cy + kBuildingYMinM;

  l.building_x_min_m = cx + kBuildingXMinM;
  l.building_x_max_m = l.building_x_min_m + kBuildingXM;
  l.building_y_min_m = cy + kBuildingYMinM;
  l.building_y_max_m = l.building_y_min_m + kBuildingYM;
  l.upper_floor_z_m = kUpperFloorZM;
  l.upper_floor_underside_z_m = kUpperFloorZM - kSlabM;
  l.roof_z_m = kRoofZM;
  l.roof_underside_z_m = kRoofZM - kSlabM;
  const double ramp_y0 = l.building_y_min_m + 0.5 * (kBuildingYM - kBuildingRampWidthM);
  const double ramp_x0 = l.building_x_min_m + kBuildingRampToeM;
  l.building_ramp = {ramp_x0,      ramp_x0 + kUpperFloorZM / tan_slope,
                     ramp_y0,      ramp_y0 + kBuildingRampWidthM,
                     0.0,          kUpperFloorZM,
                     Vec2::UnitX()};
  // The west door faces the ramp's toe; the south door faces the road.
  l.west_door = {ramp_y0, ramp_y0 + kBuildingRampWidthM, 0.0, kDoorTopM};
  const double road_mid_x = 0.5 * (l.road_x_min_m + l.road_x_max_m);
  l.south_door = {road_mid_x - 0.5 * kSouthDoorWidthM, road_mid_x + 0.5 * kSouthDoorWidthM, 0.0,
                  kDoorTopM};
  l.partition_x_m = l.building_x_min_m + kPartitionFromWestM;
  const double mid_y = 0.5 * (l.building_y_min_m + l.building_y_max_m);
  l.partition_door = {mid_y - 0.5 * kPartitionDoorWidthM, mid_y + 0.5 * kPartitionDoorWidthM,
                      kUpperFloorZM, kUpperFloorZM + kPartitionDoorTopM};

  const double end = std::max(kQueryEndMinM, kQueryEndFraction * size);
  const std::array<Vec2, 2> hill_ends = {Vec2(end, end), Vec2(size - end, size - end)};

  std::mt19937 rng = MakeEngine(seed, kSiteLayoutStream);
  DrawHills(rng, &l);
  PlaceHeaps(rng, hill_ends, &l);
  PlaceObstacles(rng, hill_ends, &l);

  l.assessment_resolution_m = 0.2;
  const auto on_ground = [&l](const Vec2& p) {
    return Vec3(p.x(), p.y(), l.GroundZAt(p.x(), p.y()));
  };
  const Vec2 c(cx, cy);
  const double building_mid_y = mid_y;
  l.queries = {
      {"across_the_hills", on_ground(hill_ends[0]), on_ground(hill_ends[1]), "differential"},
      {"ground_to_bridge_deck", on_ground(c + Vec2(2.0, 2.0)),
       Vec3(cx + 0.5 * kCompoundXM, 0.5 * (l.bridge_y_min_m + l.bridge_y_max_m), kDeckZM),
       "differential"},
      {"under_the_bridge", on_ground(Vec2(road_mid_x, cy + 1.0)),
       on_ground(Vec2(road_mid_x, l.building_y_min_m - 2.0)), "differential"},
      {"ground_to_upper_floor", on_ground(Vec2(l.building_x_min_m - 4.0, building_mid_y)),
       Vec3(l.building_x_max_m - 3.0, building_mid_y, kUpperFloorZM), "differential"},
  };
  return l;
}

PointCloud Generate(std::uint32_t seed, double size_m, double spacing_m) {
  if (!IsValidSpacing(spacing_m) || !(size_m >= kOutdoorSiteMinSizeM) ||
      !(size_m <= kOutdoorSiteMaxSizeM)) {
    return {};
  }
  const OutdoorSiteLayout l = BuildLayout(seed, size_m);
  SurfaceSampler s(seed, spacing_m);
  s.Reserve(PointBound(l, spacing_m));
  SampleGround(s, l);
  SampleStructures(s, l);
  return std::move(s).TakeCloud();
}

}  // namespace

std::size_t OutdoorSitePointBound(std::uint32_t seed, double size_m, double spacing_m) {
  return PointBound(BuildLayout(seed, size_m), spacing_m);
}

}  // namespace internal

double OutdoorSiteLayout::GroundZAt(double x_m, double y_m) const {
  internal::GroundColumn column(*this);
  column.MoveTo(x_m);
  return column.HeightAt(y_m);
}

bool OutdoorSiteLayout::OnPad(double x_m, double y_m) const {
  return x_m >= pad_x_min_m && x_m <= pad_x_max_m && y_m >= pad_y_min_m && y_m <= pad_y_max_m;
}

bool OutdoorSiteLayout::HasUpperFloor(double x_m, double y_m) const {
  const bool inside = x_m >= building_x_min_m && x_m <= building_x_max_m &&
                      y_m >= building_y_min_m && y_m <= building_y_max_m;
  const SceneRamp& r = building_ramp;
  return inside && !(internal::StrictlyInside(x_m, r.x_min_m, r.x_max_m) &&
                     internal::StrictlyInside(y_m, r.y_min_m, r.y_max_m));
}

OutdoorSiteLayout GetOutdoorSiteLayout(std::uint32_t seed, double size_m) {
  return internal::BuildLayout(seed, size_m);
}

PointCloud GenerateOutdoorSite(std::uint32_t seed, double size_m, double spacing_m) {
  return internal::Generate(seed, size_m, spacing_m);
}

}  // namespace strata
