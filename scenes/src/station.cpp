// abandoned_station: track bed, platform and a mezzanine with a collapsed section.
#include <algorithm>
#include <cmath>

#include "scenes_internal.hpp"

namespace strata {
namespace {

using internal::AddSolidRamp;
using internal::kDegToRad;
using internal::KeepFn;
using internal::kEpsM;
using internal::StrictlyInside;
using internal::Vec2;
using internal::Vec3;

constexpr double kHallXM = 48.0, kHallYM = 24.0;
constexpr double kTrackYMaxM = 8.0;
constexpr int kStairRisers = 7;
constexpr double kRiserM = 0.15, kTreadM = 0.3;
constexpr double kPlatformZM = kStairRisers * kRiserM;  // 1.05 m.
constexpr double kMezzanineZM = 4.05, kMezzanineThicknessM = 0.25;
constexpr double kMezzanineYMinM = 16.0;
constexpr double kRampSlopeDeg = 11.0;
constexpr double kRampWidthM = 3.5;
constexpr double kTongueDepthM = 3.5;    // Along x.
constexpr double kCollapseWidthM = 6.0;  // Along x, from the west ramp's toe.
constexpr double kBrokenSlabSlopeDeg = 32.0;
constexpr double kRailingM = 1.0;

}  // namespace

bool StationLayout::IsOverMezzanine(double x_m, double y_m) const {
  if (x_m < 0 || x_m > x_max_m || y_m < 0 || y_m > y_max_m) return false;
  for (const Eigen::Vector4d& t : tongues_m) {
    if (x_m >= t[0] && x_m <= t[1] && y_m >= t[2] && y_m <= t[3]) return true;
  }
  return y_m >= mezzanine_y_min_m && !(x_m > collapse_x_min_m && x_m < collapse_x_max_m);
}

bool StationLayout::InCollapse(double x_m, double y_m) const {
  return x_m >= collapse_x_min_m && x_m <= collapse_x_max_m && y_m >= collapse_y_min_m &&
         y_m <= collapse_y_max_m;
}

StationLayout GetStationLayout() {
  StationLayout l{};
  l.x_max_m = kHallXM;
  l.y_max_m = kHallYM;
  l.track_z_m = 0.0;
  l.track_y_max_m = kTrackYMaxM;
  l.platform_z_m = kPlatformZM;
  l.mezzanine_z_m = kMezzanineZM;
  l.mezzanine_underside_z_m = kMezzanineZM - kMezzanineThicknessM;
  l.mezzanine_y_min_m = kMezzanineYMinM;
  l.railing_height_m = kRailingM;
  const double tan_ramp = std::tan(kRampSlopeDeg * kDegToRad);

  // Track bed → platform: 3.5 m wide, rising along +y to the platform edge.
  const double track_run = kPlatformZM / tan_ramp;
  for (const double x0 : {2.0, 42.5}) {
    l.track_ramps.push_back({x0, x0 + kRampWidthM, kTrackYMaxM - track_run, kTrackYMaxM, 0.0,
                             kPlatformZM, Vec2::UnitY()});
  }
  l.stair_risers = kStairRisers;
  l.riser_m = kRiserM;
  l.tread_m = kTreadM;
  const double stairs_depth = (kStairRisers - 1) * kTreadM;
  for (const double x0 : {8.0, 38.0}) {
    l.stairs_m.emplace_back(x0, x0 + 2.0, kTrackYMaxM - stairs_depth, kTrackYMaxM);
  }

  // Platform → mezzanine: in front of the mezzanine (y in [12.5, 16]), rising outwards to a
  // tongue at each end of the hall.
  const double mezz_run = (kMezzanineZM - kPlatformZM) / tan_ramp;
  const double ramp_y0 = kMezzanineYMinM - kRampWidthM;
  l.mezzanine_ramps.push_back({kTongueDepthM, kTongueDepthM + mezz_run, ramp_y0, kMezzanineYMinM,
                               kPlatformZM, kMezzanineZM, -Vec2::UnitX()});
  l.mezzanine_ramps.push_back({kHallXM - kTongueDepthM - mezz_run, kHallXM - kTongueDepthM, ramp_y0,
                               kMezzanineYMinM, kPlatformZM, kMezzanineZM, Vec2::UnitX()});
  l.tongues_m.emplace_back(0.0, kTongueDepthM, ramp_y0, kMezzanineYMinM);
  // The collapse starts at the west ramp's toe, so its debris and the ramp's railing close the
  // front of the space under the mezzanine's west part without a gap.
  l.collapse_x_min_m = l.mezzanine_ramps[0].x_max_m;
  l.collapse_x_max_m = l.collapse_x_min_m + kCollapseWidthM;
  l.collapse_y_min_m = kMezzanineYMinM;
  l.collapse_y_max_m = kHallYM;
  l.broken_slab_foot_x_m =
      l.collapse_x_min_m + (kMezzanineZM - kPlatformZM) / std::tan(kBrokenSlabSlopeDeg * kDegToRad);
  l.tongues_m.emplace_back(kHallXM - kTongueDepthM, kHallXM, ramp_y0, kMezzanineYMinM);

  l.pillar_radius_m = 0.3;
  for (const double x : {3.0, 9.0, 15.0, 29.0, 35.0, 41.0, 46.0}) {
    l.pillar_centers_m.emplace_back(x, 20.0);
  }
  l.column_radius_m = 0.35;
  l.column_height_m = 3.0;
  for (const double x : {16.0, 24.0, 32.0}) l.column_centers_m.emplace_back(x, 4.0);

  // Rubble: a packed pile of blocks between the broken slab's foot and the east part, gaps of
  // 0.1 m, heights 0.35–0.85 m from a fixed pattern (not the seed).
  const double x0 = l.broken_slab_foot_x_m, x1 = l.collapse_x_max_m;
  constexpr int kRubbleX = 2, kRubbleY = 12;
  for (int i = 0; i < kRubbleX; ++i) {
    for (int j = 0; j < kRubbleY; ++j) {
      const double bx0 = x0 + (x1 - x0) * i / kRubbleX, bx1 = x0 + (x1 - x0) * (i + 1) / kRubbleX;
      const double by0 = kMezzanineYMinM + (kHallYM - kMezzanineYMinM) * j / kRubbleY;
      const double by1 = kMezzanineYMinM + (kHallYM - kMezzanineYMinM) * (j + 1) / kRubbleY;
      const double h = 0.35 + 0.5 * std::fmod(0.37 * (7 * i + 3 * j + 1), 1.0);
      l.rubble_m.emplace_back(Vec3(bx0 + 0.05, by0 + 0.05, kPlatformZM),
                              Vec3(bx1 - 0.05, by1 - 0.05, kPlatformZM + h));
    }
  }

  l.assessment_resolution_m = 0.2;
  l.queries = {
      {"track_to_mezzanine_east", {22.0, 2.0, 0.0}, {36.0, 20.0, kMezzanineZM}, "differential"},
      {"mezzanine_west_to_east",
       {9.0, 22.0, kMezzanineZM},
       {36.0, 22.0, kMezzanineZM},
       "differential"},
      {"under_mezzanine_to_track_east",
       {12.0, 19.0, kPlatformZM},
       {35.0, 2.0, 0.0},
       "differential"},
  };
  return l;
}

PointCloud GenerateAbandonedStation(std::uint32_t seed, double spacing_m) {
  if (!internal::IsValidSpacing(spacing_m)) return {};
  const StationLayout l = GetStationLayout();
  internal::SurfaceSampler s(seed, spacing_m);
  const double pz = l.platform_z_m, mz = l.mezzanine_z_m, mu = l.mezzanine_underside_z_m;
  const double rail = l.railing_height_m;

  const auto in_rect = [](const Eigen::Vector4d& r, double x, double y) {
    return StrictlyInside(x, r[0], r[1]) && StrictlyInside(y, r[2], r[3]);
  };
  const auto in_ramp = [](const SceneRamp& r, double x, double y) {
    return StrictlyInside(x, r.x_min_m, r.x_max_m) && StrictlyInside(y, r.y_min_m, r.y_max_m);
  };
  const auto in_circle = [](const std::vector<Eigen::Vector2d>& centres, double radius, double x,
                            double y) {
    return std::any_of(centres.begin(), centres.end(), [&](const Eigen::Vector2d& c) {
      return (Vec2(x, y) - c).norm() < radius - kEpsM;
    });
  };

  // Track bed, except under its ramps, stairs and columns.
  s.AddHorizontalRect(0.0, l.x_max_m, 0.0, l.track_y_max_m, l.track_z_m, [&](const Vec3& p) {
    return std::none_of(l.track_ramps.begin(), l.track_ramps.end(),
                        [&](const SceneRamp& r) { return in_ramp(r, p.x(), p.y()); }) &&
           std::none_of(l.stairs_m.begin(), l.stairs_m.end(),
                        [&](const Eigen::Vector4d& r) { return in_rect(r, p.x(), p.y()); }) &&
           !in_circle(l.column_centers_m, l.column_radius_m, p.x(), p.y());
  });
  for (const Eigen::Vector2d& c : l.column_centers_m) {
    s.AddVerticalCylinder(c.x(), c.y(), l.column_radius_m, l.track_z_m, l.column_height_m);
    s.AddDisc({c.x(), c.y(), l.column_height_m}, Vec3::UnitZ(), l.column_radius_m);
  }

  // Platform edge: the block's front face below, a railing above, both open where a ramp or
  // a flight of stairs arrives.
  const auto at_arrival = [&](const Vec3& p) {
    return std::any_of(
               l.track_ramps.begin(), l.track_ramps.end(),
               [&](const SceneRamp& r) { return StrictlyInside(p.x(), r.x_min_m, r.x_max_m); }) ||
           std::any_of(l.stairs_m.begin(), l.stairs_m.end(),
                       [&](const Eigen::Vector4d& r) { return StrictlyInside(p.x(), r[0], r[1]); });
  };
  s.AddVerticalRect({0.0, l.track_y_max_m}, {l.x_max_m, l.track_y_max_m}, l.track_z_m, pz + rail,
                    [&](const Vec3& p) { return !at_arrival(p); });
  for (const SceneRamp& r : l.track_ramps) {
    AddSolidRamp(s, r, /*with_sides=*/true, rail, /*back_bottom_z_m=*/r.z_high_m);
  }
  for (const Eigen::Vector4d& st : l.stairs_m) {
    for (int k = 0; k < l.stair_risers; ++k) {
      const double y = st[2] + k * l.tread_m;
      s.AddVerticalRect({st[0], y}, {st[1], y}, k * l.riser_m, (k + 1) * l.riser_m);
      if (k + 1 < l.stair_risers) {
        s.AddHorizontalRect(st[0], st[1], y, y + l.tread_m, (k + 1) * l.riser_m);
      }
    }
    const auto below_profile = [&](const Vec3& p) {
      const int step = static_cast<int>(std::floor((p.y() - st[2]) / l.tread_m + kEpsM));
      return p.z() <= std::min(step + 1, l.stair_risers) * l.riser_m + kEpsM;
    };
    for (const double x : {st[0], st[1]}) {
      s.AddVerticalRect({x, st[2]}, {x, st[3]}, 0.0, pz, below_profile);
    }
  }

  // Platform top, except under the mezzanine ramps, the broken slab, the rubble and pillars.
  const auto under_rubble = [&](double x, double y) {
    return std::any_of(l.rubble_m.begin(), l.rubble_m.end(), [&](const auto& b) {
      return StrictlyInside(x, b.first.x(), b.second.x()) &&
             StrictlyInside(y, b.first.y(), b.second.y());
    });
  };
  const auto under_slab = [&](double x, double y) {
    return StrictlyInside(x, l.collapse_x_min_m, l.broken_slab_foot_x_m) &&
           y > l.collapse_y_min_m - kEpsM;
  };
  s.AddHorizontalRect(0.0, l.x_max_m, l.track_y_max_m, l.y_max_m, pz, [&](const Vec3& p) {
    return std::none_of(l.mezzanine_ramps.begin(), l.mezzanine_ramps.end(),
                        [&](const SceneRamp& r) { return in_ramp(r, p.x(), p.y()); }) &&
           !under_slab(p.x(), p.y()) && !under_rubble(p.x(), p.y()) &&
           !in_circle(l.pillar_centers_m, l.pillar_radius_m, p.x(), p.y());
  });
  for (const auto& b : l.rubble_m) s.AddBoxSurfaces(b.first, b.second, /*with_bottom=*/false);
  for (const Eigen::Vector2d& c : l.pillar_centers_m) {
    s.AddVerticalCylinder(c.x(), c.y(), l.pillar_radius_m, pz, mu);
  }

  // Mezzanine: top and underside of the main part (without the collapsed gap) and of the
  // tongues; the underside is hidden only where the pillars meet it.
  const auto add_mezzanine_face = [&](double z, const KeepFn& keep) {
    s.AddHorizontalRect(0.0, l.collapse_x_min_m, l.mezzanine_y_min_m, l.y_max_m, z, keep);
    s.AddHorizontalRect(l.collapse_x_max_m, l.x_max_m, l.mezzanine_y_min_m, l.y_max_m, z, keep);
    for (const Eigen::Vector4d& t : l.tongues_m) {
      s.AddHorizontalRect(t[0], t[1], t[2], t[3], z, [&](const Vec3& p) {
        return p.y() < l.mezzanine_y_min_m - kEpsM && (!keep || keep(p));
      });
    }
  };
  add_mezzanine_face(mz, {});
  add_mezzanine_face(mu, [&](const Vec3& p) {
    return !in_circle(l.pillar_centers_m, l.pillar_radius_m, p.x(), p.y());
  });

  // Mezzanine ramps: solid wedges whose sides carry the railing; the back face stands under
  // the tongue. The mezzanine's own front edge (slab edge and railing) is sampled only above
  // a ramp's railing where the two share the line y = 16.
  for (const SceneRamp& r : l.mezzanine_ramps) {
    AddSolidRamp(s, r, /*with_sides=*/true, rail, /*back_bottom_z_m=*/pz);
  }
  const auto above_ramp_railing = [&](const Vec3& p) {
    return std::none_of(l.mezzanine_ramps.begin(), l.mezzanine_ramps.end(),
                        [&](const SceneRamp& r) {
                          return p.x() >= r.x_min_m - kEpsM && p.x() <= r.x_max_m + kEpsM &&
                                 p.z() <= r.TopZAt(p.x(), p.y()) + rail + kEpsM;
                        });
  };
  const double front = l.mezzanine_y_min_m;
  s.AddVerticalRect({l.tongues_m[0][1], front}, {l.collapse_x_min_m, front}, mu, mz + rail,
                    above_ramp_railing);
  s.AddVerticalRect({l.collapse_x_max_m, front}, {l.tongues_m[1][0], front}, mu, mz + rail,
                    above_ramp_railing);
  for (const Eigen::Vector4d& t : l.tongues_m) {
    s.AddVerticalRect({t[0], t[2]}, {t[1], t[2]}, mu, mz + rail);
  }
  // East part's edge over the collapse; the west part breaks off into the hanging slab.
  s.AddVerticalRect({l.collapse_x_max_m, front}, {l.collapse_x_max_m, l.y_max_m}, mu, mz + rail);
  // Outer parapets of the mezzanine (the tongues' and main part's ends) and of the platform.
  for (const double x : {0.0, l.x_max_m}) {
    s.AddVerticalRect({x, l.tongues_m[0][2]}, {x, l.y_max_m}, mu, mz + rail);
    s.AddVerticalRect({x, l.track_y_max_m}, {x, l.y_max_m}, pz, pz + rail);
  }
  // Back wall, from the platform to the mezzanine's railing height; hidden behind the slab.
  s.AddVerticalRect({0.0, l.y_max_m}, {l.x_max_m, l.y_max_m}, pz, mz + rail, [&](const Vec3& p) {
    const bool behind_slab =
        p.z() > mu + kEpsM && p.z() < mz - kEpsM && l.IsOverMezzanine(p.x(), l.y_max_m);
    return !behind_slab;
  });

  // The collapse: the west part's slab hangs at 32° from x = collapse_x_min onto the platform,
  // resting on a solid heap of debris (its front face and the vertical face under the break
  // are sampled; the back one is against the wall).
  const double foot = l.broken_slab_foot_x_m;
  s.AddInclinedRect({foot, l.collapse_y_min_m}, {foot, l.collapse_y_max_m}, pz,
                    Vec2(l.collapse_x_min_m - foot, 0.0), mz - pz);
  s.AddVerticalTrapezoid({l.collapse_x_min_m, front}, {foot, front}, pz, mz, pz);
  s.AddVerticalRect({l.collapse_x_min_m, front}, {l.collapse_x_min_m, l.y_max_m}, pz, mu);
  return std::move(s).TakeCloud();
}

}  // namespace strata
