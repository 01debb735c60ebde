// indoor_tables: a room with low tables, one row spanning it wall to wall, and chairs.
#include <algorithm>
#include <cmath>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::kEpsM;
using internal::StrictlyInside;
using internal::Vec2;
using internal::Vec3;

constexpr double kRoomXM = 12.0, kRoomYM = 9.0, kWallM = 2.0;
// Under 0.5 m: the biped's lowest body (0.35 m) plus headroom (0.05 m) fits, the differential
// robot's 0.5 m body plus 0.05 m does not.
constexpr double kUndersideM = 0.5, kTopThicknessM = 0.04;
constexpr double kLegRadiusM = 0.025, kLegInsetM = 0.06;
constexpr int kRowTables = 6;
constexpr double kRowYMinM = 5.0, kRowDepthM = 0.8;
constexpr double kSeatM = 0.42, kSeatZM = 0.45, kSeatThicknessM = 0.03, kBackTopM = 0.9;
constexpr double kChairLegRadiusM = 0.015, kChairLegInsetM = 0.03;

}  // namespace

IndoorTablesLayout GetIndoorTablesLayout() {
  IndoorTablesLayout l{};
  l.x_max_m = kRoomXM;
  l.y_max_m = kRoomYM;
  l.wall_height_m = kWallM;
  l.table_underside_z_m = kUndersideM;
  l.table_top_z_m = kUndersideM + kTopThicknessM;
  l.leg_radius_m = kLegRadiusM;
  l.leg_inset_m = kLegInsetM;
  l.row_y_min_m = kRowYMinM;
  l.row_y_max_m = kRowYMinM + kRowDepthM;
  const double table_x = kRoomXM / kRowTables;
  for (int i = 0; i < kRowTables; ++i) {
    l.tables.push_back({i * table_x, (i + 1) * table_x, l.row_y_min_m, l.row_y_max_m});
  }
  l.row_tables = kRowTables;
  // Two dining tables in front of the row, one behind it.
  l.tables.push_back({2.0, 3.6, 1.8, 2.7});
  l.tables.push_back({7.5, 9.1, 2.2, 3.1});
  l.tables.push_back({8.0, 9.6, 7.3, 8.2});
  l.chair_seat_size_m = kSeatM;
  l.chair_seat_z_m = kSeatZM;
  l.chair_back_top_z_m = kBackTopM;
  const Vec2 south = -Vec2::UnitY(), north = Vec2::UnitY();
  l.chairs = {{2.4, 1.45, south},         {3.2, 1.45, south}, {2.4, 3.05, north},
              {3.2, 3.05, north},         {7.9, 1.85, south}, {8.7, 1.85, south},
              {7.9, 3.45, north},         {8.7, 3.45, north}, {7.65, 7.75, -Vec2::UnitX()},
              {9.95, 7.75, Vec2::UnitX()}};
  l.assessment_resolution_m = 0.1;
  l.queries = {
      {"front_around_tables", {1.0, 1.0, 0.0}, {11.0, 4.0, 0.0}, "differential"},
      {"under_the_row", {5.0, 1.0, 0.0}, {5.0, 7.5, 0.0}, "biped"},
      {"front_left_to_back_right", {1.0, 1.0, 0.0}, {11.0, 8.2, 0.0}, "biped"},
  };
  return l;
}

PointCloud GenerateIndoorTables(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const IndoorTablesLayout l = GetIndoorTablesLayout();
  internal::SurfaceSampler s(seed, spacing_m);

  s.AddHorizontalRect(0.0, l.x_max_m, 0.0, l.y_max_m, 0.0);
  // Walls, except behind the row's ends, which touch them.
  internal::AddRoomWalls(s, l.x_max_m, l.y_max_m, 0.0, l.wall_height_m, [&](const Vec3& p) {
    return !(StrictlyInside(p.y(), l.row_y_min_m, l.row_y_max_m) &&
             StrictlyInside(p.z(), l.table_underside_z_m, l.table_top_z_m));
  });

  // Tables: top, underside and edges; the row's tables abut each other and the walls, so their
  // end faces are not sampled.
  for (std::size_t i = 0; i < l.tables.size(); ++i) {
    const auto& t = l.tables[i];
    const bool in_row = static_cast<int>(i) < l.row_tables;
    s.AddBoxSurfaces(
        {t.x_min_m, t.y_min_m, l.table_underside_z_m}, {t.x_max_m, t.y_max_m, l.table_top_z_m},
        /*with_bottom=*/true, [&](const Vec3& p) {
          // A row table's end faces (x = its x_min/x_max) are hidden.
          const bool end_face =
              (std::abs(p.x() - t.x_min_m) < kEpsM || std::abs(p.x() - t.x_max_m) < kEpsM) &&
              StrictlyInside(p.z(), l.table_underside_z_m, l.table_top_z_m);
          return !(in_row && end_face);
        });
    for (const double x : {t.x_min_m + l.leg_inset_m, t.x_max_m - l.leg_inset_m}) {
      for (const double y : {t.y_min_m + l.leg_inset_m, t.y_max_m - l.leg_inset_m}) {
        s.AddVerticalCylinder(x, y, l.leg_radius_m, 0.0, l.table_underside_z_m);
      }
    }
  }

  // Chairs: a thin seat on four legs and a backrest sheet on the back edge.
  const double half = 0.5 * l.chair_seat_size_m;
  for (const auto& c : l.chairs) {
    const double seat_bottom = l.chair_seat_z_m - kSeatThicknessM;
    s.AddBoxSurfaces({c.x_m - half, c.y_m - half, seat_bottom},
                     {c.x_m + half, c.y_m + half, l.chair_seat_z_m}, /*with_bottom=*/true);
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        s.AddVerticalCylinder(c.x_m + sx * (half - kChairLegInsetM),
                              c.y_m + sy * (half - kChairLegInsetM), kChairLegRadiusM, 0.0,
                              seat_bottom);
      }
    }
    const Vec2 centre(c.x_m, c.y_m);
    const Vec2 back = centre + half * c.back_dir;
    const Vec2 across(-c.back_dir.y(), c.back_dir.x());
    s.AddVerticalRect(back - half * across, back + half * across, l.chair_seat_z_m,
                      l.chair_back_top_z_m);
  }
  return std::move(s).TakeCloud();
}

}  // namespace strata
