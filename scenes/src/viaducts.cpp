// crossing_viaducts: two viaducts on piers, one over the other, with a road under the crossing.
#include <algorithm>
#include <cmath>
#include <limits>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::AddSolidRamp;
using internal::kDegToRad;
using internal::kEpsM;
using internal::StrictlyInside;
using internal::Vec2;
using internal::Vec3;

constexpr double kSizeM = 88.0;
constexpr double kCentreM = 44.0;  // The crossing.
constexpr double kDeckWidthM = 5.0, kDeckThicknessM = 0.4, kRailingM = 1.0;
constexpr double kRampSlopeDeg = 12.0;
constexpr double kAZM = 4.5, kBZM = 7.0;
constexpr double kAToeXM = 4.0;      // A's west toe; its east toe mirrors it.
constexpr double kBSpanHalfM = 8.0;  // B is elevated for |y - centre| <= this.
constexpr double kPierRadiusM = 0.8;
constexpr double kRoadWidthM = 6.0;

double DeckZ(const std::vector<SceneRamp>& ramps, double span_lo, double span_hi, bool along_x,
             double deck_z, double across_lo, double across_hi, double x, double y) {
  const double along = along_x ? x : y, across = along_x ? y : x;
  if (across < across_lo || across > across_hi) return std::numeric_limits<double>::quiet_NaN();
  if (along >= span_lo && along <= span_hi) return deck_z;
  for (const SceneRamp& r : ramps) {
    if (r.Contains(x, y)) return r.TopZAt(x, y);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

double ViaductsLayout::GroundZAt(double x_m, double y_m) const {
  double z = 0.0;
  for (const Mound& m : mounds) {
    const double d2 = (x_m - m.x_m) * (x_m - m.x_m) + (y_m - m.y_m) * (y_m - m.y_m);
    z += m.height_m * std::exp(-d2 / (2.0 * m.sigma_m * m.sigma_m));
  }
  return z;
}

double ViaductsLayout::RoadDistance(double x_m, double y_m) const {
  const Vec2 d = Vec2(x_m, y_m) - road_point_m;
  return std::abs(d.x() * road_dir.y() - d.y() * road_dir.x());
}

double ViaductsLayout::AZAt(double x_m, double y_m) const {
  return DeckZ(a_ramps, a_ramps[0].x_max_m, a_ramps[1].x_min_m, /*along_x=*/true, a_z_m, a_y_min_m,
               a_y_max_m, x_m, y_m);
}

double ViaductsLayout::BZAt(double x_m, double y_m) const {
  return DeckZ(b_ramps, b_ramps[0].y_max_m, b_ramps[1].y_min_m, /*along_x=*/false, b_z_m, b_x_min_m,
               b_x_max_m, x_m, y_m);
}

ViaductsLayout GetViaductsLayout() {
  ViaductsLayout l{};
  l.size_m = kSizeM;
  // Low mounds (slopes <= 1.2/5·e^(-1/2) = 0.15, under 9°), each at least three widths away
  // from the road and the viaducts, so the ground under them stays flat (to 0.3 mm).
  l.mounds = {{20.0, 68.0, 1.2, 5.0},
              {68.0, 20.0, 1.2, 5.0},
              {75.0, 58.0, 0.8, 3.0},
              {13.0, 30.0, 0.8, 3.0}};
  l.deck_width_m = kDeckWidthM;
  l.deck_thickness_m = kDeckThicknessM;
  l.railing_height_m = kRailingM;
  const double tan_slope = std::tan(kRampSlopeDeg * kDegToRad);

  l.a_z_m = kAZM;
  l.a_y_min_m = kCentreM - 0.5 * kDeckWidthM;
  l.a_y_max_m = kCentreM + 0.5 * kDeckWidthM;
  l.a_x_min_m = kAToeXM;
  l.a_x_max_m = kSizeM - kAToeXM;
  const double a_run = kAZM / tan_slope;
  l.a_ramps = {
      {l.a_x_min_m, l.a_x_min_m + a_run, l.a_y_min_m, l.a_y_max_m, 0.0, kAZM, Vec2::UnitX()},
      {l.a_x_max_m - a_run, l.a_x_max_m, l.a_y_min_m, l.a_y_max_m, 0.0, kAZM, -Vec2::UnitX()}};

  l.b_z_m = kBZM;
  l.b_x_min_m = kCentreM - 0.5 * kDeckWidthM;
  l.b_x_max_m = kCentreM + 0.5 * kDeckWidthM;
  const double b_run = kBZM / tan_slope;
  l.b_y_min_m = kCentreM - kBSpanHalfM - b_run;
  l.b_y_max_m = kCentreM + kBSpanHalfM + b_run;
  l.b_ramps = {
      {l.b_x_min_m, l.b_x_max_m, l.b_y_min_m, kCentreM - kBSpanHalfM, 0.0, kBZM, Vec2::UnitY()},
      {l.b_x_min_m, l.b_x_max_m, kCentreM + kBSpanHalfM, l.b_y_max_m, 0.0, kBZM, -Vec2::UnitY()}};

  l.pier_radius_m = kPierRadiusM;
  // On the axes, clear of the road by >= 1 m.
  l.a_piers_m = {{29.0, kCentreM}, {35.0, kCentreM}, {53.0, kCentreM}, {59.0, kCentreM}};
  l.b_piers_m = {{kCentreM, kCentreM - 6.8}, {kCentreM, kCentreM + 6.8}};
  l.road_point_m = Vec2(kCentreM, kCentreM);
  l.road_dir = Vec2(1.0, 1.0).normalized();
  l.road_width_m = kRoadWidthM;

  l.assessment_resolution_m = 0.2;
  l.queries = {
      {"along_road_under_crossing", {14.0, 14.0, 0.0}, {74.0, 74.0, 0.0}, "differential"},
      {"ground_to_a_under_b", {2.0, kCentreM, 0.0}, {kCentreM, kCentreM, kAZM}, "differential"},
      {"ground_to_b_over_a", {kCentreM, 1.5, 0.0}, {kCentreM, kCentreM, kBZM}, "differential"},
  };
  return l;
}

PointCloud GenerateCrossingViaducts(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const ViaductsLayout l = GetViaductsLayout();
  internal::SurfaceSampler s(seed, spacing_m);
  const double rail = l.railing_height_m;
  const double a_under = l.a_z_m - l.deck_thickness_m, b_under = l.b_z_m - l.deck_thickness_m;

  const auto on_ramp = [&](double x, double y) {
    for (const auto* ramps : {&l.a_ramps, &l.b_ramps}) {
      for (const SceneRamp& r : *ramps) {
        if (StrictlyInside(x, r.x_min_m, r.x_max_m) && StrictlyInside(y, r.y_min_m, r.y_max_m)) {
          return true;
        }
      }
    }
    return false;
  };
  const auto in_pier = [&](double x, double y) {
    for (const auto* piers : {&l.a_piers_m, &l.b_piers_m}) {
      for (const Eigen::Vector2d& c : *piers) {
        if ((Vec2(x, y) - c).norm() < l.pier_radius_m - kEpsM) return true;
      }
    }
    return false;
  };

  s.AddHeightField(
      0.0, l.size_m, 0.0, l.size_m, [&l](double x, double y) { return l.GroundZAt(x, y); },
      [&](const Vec3& p) { return !on_ramp(p.x(), p.y()) && !in_pier(p.x(), p.y()); });

  // Ramps (solid embankments whose sides carry the railing) and the abutment under each
  // ramp's top end.
  for (const auto* ramps : {&l.a_ramps, &l.b_ramps}) {
    for (const SceneRamp& r : *ramps) {
      AddSolidRamp(s, r, /*with_sides=*/true, rail, /*back_bottom_z_m=*/r.z_high_m);
      const double under = r.z_high_m - l.deck_thickness_m;
      if (std::abs(r.uphill_dir.x()) > 0.5) {
        const double x = r.uphill_dir.x() > 0 ? r.x_max_m : r.x_min_m;
        s.AddVerticalRect({x, r.y_min_m}, {x, r.y_max_m}, 0.0, under);
      } else {
        const double y = r.uphill_dir.y() > 0 ? r.y_max_m : r.y_min_m;
        s.AddVerticalRect({r.x_min_m, y}, {r.x_max_m, y}, 0.0, under);
      }
    }
  }

  // Elevated spans: top, underside (hidden where piers meet it), and the slab edge plus
  // railing as one sheet on each side. A's top under B is open: B passes 2.1 m above it.
  const double a_x0 = l.a_ramps[0].x_max_m, a_x1 = l.a_ramps[1].x_min_m;
  const double b_y0 = l.b_ramps[0].y_max_m, b_y1 = l.b_ramps[1].y_min_m;
  s.AddHorizontalRect(a_x0, a_x1, l.a_y_min_m, l.a_y_max_m, l.a_z_m);
  s.AddHorizontalRect(a_x0, a_x1, l.a_y_min_m, l.a_y_max_m, a_under,
                      [&](const Vec3& p) { return !in_pier(p.x(), p.y()); });
  for (const double y : {l.a_y_min_m, l.a_y_max_m}) {
    s.AddVerticalRect({a_x0, y}, {a_x1, y}, a_under, l.a_z_m + rail);
  }
  s.AddHorizontalRect(l.b_x_min_m, l.b_x_max_m, b_y0, b_y1, l.b_z_m);
  s.AddHorizontalRect(l.b_x_min_m, l.b_x_max_m, b_y0, b_y1, b_under,
                      [&](const Vec3& p) { return !in_pier(p.x(), p.y()); });
  for (const double x : {l.b_x_min_m, l.b_x_max_m}) {
    s.AddVerticalRect({x, b_y0}, {x, b_y1}, b_under, l.b_z_m + rail);
  }

  for (const Eigen::Vector2d& c : l.a_piers_m) {
    s.AddVerticalCylinder(c.x(), c.y(), l.pier_radius_m, l.GroundZAt(c.x(), c.y()), a_under);
  }
  for (const Eigen::Vector2d& c : l.b_piers_m) {
    s.AddVerticalCylinder(c.x(), c.y(), l.pier_radius_m, l.GroundZAt(c.x(), c.y()), b_under);
  }
  return std::move(s).TakeCloud();
}

}  // namespace strata
