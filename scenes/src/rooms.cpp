// The two rooms: stairs_ramp_room and two_level_ramp (strata/scenes/basic_scenes.hpp).
#include "strata/scenes/basic_scenes.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::AddRoomWalls;
using internal::IsValidSpacing;
using internal::kDegToRad;
using internal::KeepFn;
using internal::kEpsM;
using internal::StrictlyInside;
using internal::SurfaceSampler;
using internal::Vec2;
using internal::Vec3;

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

}  // namespace strata
