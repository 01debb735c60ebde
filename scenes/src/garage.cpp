// parking_garage: a ground floor and three decks joined by straight ramps, with pillars, beams
// and parked cars.
#include <algorithm>
#include <cmath>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::AddSolidRamp;
using internal::kDegToRad;
using internal::kEpsM;
using internal::StrictlyInside;
using internal::Vec2;
using internal::Vec3;

constexpr double kGarageXM = 40.0, kGarageYM = 24.0;
constexpr int kLevels = 4;
constexpr double kStoreyM = 2.8;
constexpr double kSlabM = 0.25;
constexpr double kRailingM = 1.0;
constexpr double kRampSlopeDeg = 11.0;
constexpr double kRampXMinM = 14.0;
constexpr double kSouthLaneYMinM = 1.5, kNorthLaneYMinM = 19.0, kLaneWidthM = 3.5;
constexpr double kPillarM = 0.5;
constexpr double kBeamDepthM = 0.45, kBeamWidthM = 0.4;
constexpr double kCarXM = 1.9, kCarYM = 4.4, kCarZM = 1.4;

}  // namespace

bool GarageLayout::HasFloor(int level, double x_m, double y_m) const {
  if (level < 0 || level >= static_cast<int>(level_z_m.size())) return false;
  if (x_m < 0 || x_m > x_max_m || y_m < 0 || y_m > y_max_m) return false;
  if (level == 0) return true;
  const SceneRamp& r = ramps[static_cast<std::size_t>(level - 1)];
  return !(StrictlyInside(x_m, r.x_min_m, r.x_max_m) && StrictlyInside(y_m, r.y_min_m, r.y_max_m));
}

GarageLayout GetGarageLayout() {
  GarageLayout l{};
  l.x_max_m = kGarageXM;
  l.y_max_m = kGarageYM;
  for (int k = 0; k < kLevels; ++k) l.level_z_m.push_back(k * kStoreyM);
  l.slab_thickness_m = kSlabM;
  l.railing_height_m = kRailingM;
  const double run = kStoreyM / std::tan(kRampSlopeDeg * kDegToRad);
  for (int k = 0; k + 1 < kLevels; ++k) {
    // Alternating lanes, so each ramp starts where the previous one's deck is solid.
    const double y0 = k % 2 == 0 ? kSouthLaneYMinM : kNorthLaneYMinM;
    l.ramps.push_back({kRampXMinM, kRampXMinM + run, y0, y0 + kLaneWidthM, l.level_z_m[k],
                       l.level_z_m[k + 1], Vec2::UnitX()});
  }
  l.pillar_size_m = kPillarM;
  l.beam_depth_m = kBeamDepthM;
  l.beam_width_m = kBeamWidthM;
  l.beam_y_m = {8.0, 16.0};
  for (const double y : l.beam_y_m) {
    for (const double x : {4.0, 12.0, 20.0, 28.0, 36.0}) l.pillar_centers_m.emplace_back(x, y);
  }
  // Cars: a central row (bays 2.6 m apart, two bays left free as a passage between the
  // aisles, one in four more left free, shifted per level) and bays in both lanes away from
  // the ramps' ends.
  const auto add_car = [&l](double cx, double y0, double z) {
    l.cars_m.emplace_back(Vec3(cx - 0.5 * kCarXM, y0, z),
                          Vec3(cx + 0.5 * kCarXM, y0 + kCarYM, z + kCarZM));
  };
  for (int k = 0; k < kLevels; ++k) {
    const double z = l.level_z_m[k];
    for (int i = 0; i < 15; ++i) {
      if (i == 5 || i == 6 || (i + 2 * k) % 4 == 3) continue;
      add_car(2.2 + 2.6 * i, 9.4, z);
    }
    for (const double cx : {1.6, 4.2, 6.8, 9.4, 32.2, 34.8, 37.4}) {
      add_car(cx, 0.4, z);
      add_car(cx, kGarageYM - 0.4 - kCarYM, z);
    }
  }
  l.assessment_resolution_m = 0.2;
  const double deck2 = l.level_z_m[2], top = l.level_z_m[3];
  l.queries = {
      {"ground_to_deck1", {5.0, 6.5, 0.0}, {36.0, 6.5, l.level_z_m[1]}, "differential"},
      {"ground_to_roof", {5.0, 6.5, 0.0}, {6.0, 17.5, top}, "differential"},
      {"across_deck2", {3.0, 15.0, deck2}, {37.0, 6.5, deck2}, "differential"},
  };
  return l;
}

PointCloud GenerateParkingGarage(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const GarageLayout l = GetGarageLayout();
  internal::SurfaceSampler s(seed, spacing_m);
  const int levels = static_cast<int>(l.level_z_m.size());
  const double half_pillar = 0.5 * l.pillar_size_m;

  const auto in_pillar = [&](double x, double y) {
    return std::any_of(l.pillar_centers_m.begin(), l.pillar_centers_m.end(),
                       [&](const Eigen::Vector2d& c) {
                         return StrictlyInside(x, c.x() - half_pillar, c.x() + half_pillar) &&
                                StrictlyInside(y, c.y() - half_pillar, c.y() + half_pillar);
                       });
  };
  const auto in_beam = [&](double y) {
    return std::any_of(l.beam_y_m.begin(), l.beam_y_m.end(), [&](double b) {
      return StrictlyInside(y, b - 0.5 * l.beam_width_m, b + 0.5 * l.beam_width_m);
    });
  };
  const auto under_car = [&](double x, double y, double z) {
    return std::any_of(l.cars_m.begin(), l.cars_m.end(), [&](const auto& c) {
      return std::abs(c.first.z() - z) < kEpsM && StrictlyInside(x, c.first.x(), c.second.x()) &&
             StrictlyInside(y, c.first.y(), c.second.y());
    });
  };

  for (int k = 0; k < levels; ++k) {
    const double z = l.level_z_m[k];
    const bool has_storey_above = k + 1 < levels;
    const SceneRamp* ramp_up = has_storey_above ? &l.ramps[static_cast<std::size_t>(k)] : nullptr;
    const auto on_ramp_up = [&](double x, double y) {
      return ramp_up != nullptr && StrictlyInside(x, ramp_up->x_min_m, ramp_up->x_max_m) &&
             StrictlyInside(y, ramp_up->y_min_m, ramp_up->y_max_m);
    };
    // Floor (the deck's top), except in its opening and under what stands on it.
    s.AddHorizontalRect(0.0, l.x_max_m, 0.0, l.y_max_m, z, [&](const Vec3& p) {
      return l.HasFloor(k, p.x(), p.y()) && !on_ramp_up(p.x(), p.y()) &&
             !(has_storey_above && in_pillar(p.x(), p.y())) && !under_car(p.x(), p.y(), z);
    });
    if (k > 0) {
      const double under = z - l.slab_thickness_m;
      // Underside, except in the opening and where beams and pillars meet it.
      s.AddHorizontalRect(0.0, l.x_max_m, 0.0, l.y_max_m, under, [&](const Vec3& p) {
        return l.HasFloor(k, p.x(), p.y()) && !in_beam(p.y());
      });
      for (const double b : l.beam_y_m) {
        const double y0 = b - 0.5 * l.beam_width_m, y1 = b + 0.5 * l.beam_width_m;
        const double bottom = under - l.beam_depth_m;
        s.AddHorizontalRect(0.0, l.x_max_m, y0, y1, bottom,
                            [&](const Vec3& p) { return !in_pillar(p.x(), p.y()); });
        s.AddVerticalRect({0.0, y0}, {l.x_max_m, y0}, bottom, under);
        s.AddVerticalRect({0.0, y1}, {l.x_max_m, y1}, bottom, under);
      }
      // Perimeter: slab edge and parapet as one sheet.
      internal::AddRoomWalls(s, l.x_max_m, l.y_max_m, under, z + l.railing_height_m, {});
      // The opening's low end (the ramp below arrives at its high end; its sides are the
      // ramp's walls).
      const SceneRamp& below = l.ramps[static_cast<std::size_t>(k - 1)];
      s.AddVerticalRect({below.x_min_m, below.y_min_m}, {below.x_min_m, below.y_max_m}, under,
                        z + l.railing_height_m);
    }
    if (ramp_up != nullptr) {
      const double z_up = l.level_z_m[static_cast<std::size_t>(k) + 1];
      AddSolidRamp(s, *ramp_up, /*with_sides=*/false, 0.0, /*back_bottom_z_m=*/z);
      for (const double y : {ramp_up->y_min_m, ramp_up->y_max_m}) {
        s.AddVerticalRect({ramp_up->x_min_m, y}, {ramp_up->x_max_m, y}, z,
                          z_up + l.railing_height_m);
      }
      const double pillar_top = z_up - l.slab_thickness_m - l.beam_depth_m;
      for (const Eigen::Vector2d& c : l.pillar_centers_m) {
        s.AddBoxSurfaces({c.x() - half_pillar, c.y() - half_pillar, z},
                         {c.x() + half_pillar, c.y() + half_pillar, pillar_top},
                         /*with_bottom=*/false, [&](const Vec3& p) {
                           return p.z() < pillar_top - kEpsM;  // The top meets the beam.
                         });
      }
    }
  }
  for (const auto& car : l.cars_m) s.AddBoxSurfaces(car.first, car.second, /*with_bottom=*/false);
  return std::move(s).TakeCloud();
}

}  // namespace strata
