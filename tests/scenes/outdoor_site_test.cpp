// outdoor_site (strata/scenes/outdoor_site.hpp): determinism, size and point count, the
// layout's promises (gentle hills, steep heaps, obstacles apart, ramps, the pad), visible faces
// only, and after assessment at 100 m its levels and its example queries.
#include "strata/scenes/outdoor_site.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "scenes/scene_plans.hpp"
#include "strata/planner.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using test_util::Assess;
using test_util::ExpectPlans;
using test_util::HasValidLevelNear;

constexpr double kDeg = std::numbers::pi / 180.0;

// The slope of the ground at (x, y) by central differences [rad].
double SlopeAt(const OutdoorSiteLayout& l, double x, double y) {
  constexpr double h = 0.02;
  const double gx = (l.GroundZAt(x + h, y) - l.GroundZAt(x - h, y)) / (2 * h);
  const double gy = (l.GroundZAt(x, y + h) - l.GroundZAt(x, y - h)) / (2 * h);
  return std::atan(std::hypot(gx, gy));
}

bool OnHeap(const OutdoorSiteLayout& l, double x, double y) {
  return std::any_of(l.heaps.begin(), l.heaps.end(),
                     [&](const auto& h) { return std::hypot(x - h.x_m, y - h.y_m) < h.radius_m; });
}

TEST(OutdoorSiteTest, SameSeedSizeAndSpacingSameCloud) {
  const PointCloud a = GenerateOutdoorSite(7, 60.0, 0.2);
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(a == GenerateOutdoorSite(7, 60.0, 0.2));
  EXPECT_FALSE(a == GenerateOutdoorSite(8, 60.0, 0.2));
  EXPECT_FALSE(a == GenerateOutdoorSite(7, 61.0, 0.2));
  const Expected<PointCloud> named =
      GenerateScene("outdoor_site", 7, {.size_m = 60.0, .spacing_m = 0.2});
  ASSERT_TRUE(named.ok()) << named.error().message;
  EXPECT_TRUE(*named == a);
  // Without options: 100 m at 0.1 m.
  EXPECT_TRUE(GenerateScene("outdoor_site", 7).value() == GenerateOutdoorSite(7, 100.0, 0.1));
}

TEST(OutdoorSiteTest, PointsGrowWithTheAreaAndFitTheReservedBound) {
  constexpr double kSpacingM = 0.2;
  std::vector<double> counts;
  for (const double size : {100.0, 200.0, 400.0}) {
    SCOPED_TRACE("size " + std::to_string(size));
    const PointCloud cloud = GenerateOutdoorSite(3, size, kSpacingM);
    // The ground's lattice, less what footprints hide, plus obstacles and the compound (a
    // fifth of the points at 100 m).
    const double ground = std::pow(size / kSpacingM + 1, 2);
    EXPECT_GE(static_cast<double>(cloud.size()), ground * 0.95);
    EXPECT_LE(static_cast<double>(cloud.size()), ground * (size < 200 ? 1.3 : 1.15));
    // The bound is an upper bound, tight, and what was reserved: the cloud never grew.
    const double bound =
        EstimateScenePoints("outdoor_site", 3, {.size_m = size, .spacing_m = kSpacingM}).value();
    EXPECT_GE(bound, static_cast<double>(cloud.size()));
    EXPECT_LE(bound, 1.1 * static_cast<double>(cloud.size()));
    EXPECT_EQ(static_cast<double>(cloud.capacity()), bound);
    counts.push_back(static_cast<double>(cloud.size()));
  }
  EXPECT_GT(counts[1] / counts[0], 3.3);
  EXPECT_GT(counts[2] / counts[1], 3.7);
  // A finer spacing, more points; an invalid size or spacing, none.
  EXPECT_GT(GenerateOutdoorSite(3, 100.0, 0.1).size(), 3.5 * counts[0]);
  EXPECT_TRUE(GenerateOutdoorSite(3, 39.0, 0.2).empty());
  EXPECT_TRUE(GenerateOutdoorSite(3, 1001.0, 0.2).empty());
  EXPECT_TRUE(GenerateOutdoorSite(3, 100.0, 0.001).empty());
}

TEST(OutdoorSiteTest, PointsStayOnTheSiteAndOnTheGround) {
  const double size = 100.0, spacing = 0.2;
  const OutdoorSiteLayout l = GetOutdoorSiteLayout(5, size);
  const PointCloud cloud = GenerateOutdoorSite(5, size, spacing);
  const double txy = 0.1 * spacing + 1e-4;
  double lowest_ground = 1e9;
  for (double x = 0; x <= size; x += 1.0) {
    for (double y = 0; y <= size; y += 1.0)
      lowest_ground = std::min(lowest_ground, l.GroundZAt(x, y));
  }
  for (const Eigen::Vector3f& p : cloud) {
    ASSERT_TRUE(p.allFinite());
    ASSERT_TRUE(p.x() >= -txy && p.x() <= size + txy && p.y() >= -txy && p.y() <= size + txy)
        << p.transpose();
    ASSERT_GE(p.z(), lowest_ground - 0.01) << p.transpose();
  }
}

TEST(OutdoorSiteTest, LayoutKeepsItsPromisesAtEverySize) {
  for (const double size : {40.0, 60.0, 100.0, 250.0, 400.0, 1000.0}) {
    for (const std::uint32_t seed : {1u, 2u, 3u}) {
      SCOPED_TRACE("size " + std::to_string(size) + ", seed " + std::to_string(seed));
      const OutdoorSiteLayout l = GetOutdoorSiteLayout(seed, size);
      EXPECT_DOUBLE_EQ(l.size_m, size);
      // The compound, on the pad, inside the site; the pad is level at 0.
      EXPECT_GE(l.bridge_ramps[0].x_min_m, 0.0);
      EXPECT_LE(l.bridge_ramps[1].x_max_m, size);
      EXPECT_GE(l.compound_y_min_m, 0.0);
      EXPECT_LE(l.building_y_max_m, size);
      for (const double x : {l.pad_x_min_m, l.building_x_min_m, l.pad_x_max_m}) {
        for (const double y : {l.pad_y_min_m, l.bridge_y_min_m, l.pad_y_max_m}) {
          EXPECT_EQ(l.GroundZAt(x, y), 0.0) << x << ", " << y;
        }
      }
      std::vector<SceneRamp> ramps = l.bridge_ramps;
      ramps.push_back(l.building_ramp);
      for (const SceneRamp& r : ramps) {
        EXPECT_LE(r.SlopeRad(), 12.0 * kDeg + 1e-9);
        EXPECT_GE(r.Width(), 3.0);
        EXPECT_EQ(r.z_low_m, 0.0);
      }
      EXPECT_GT(l.bridge_deck_underside_z_m, 2.0);  // Room to drive under the deck.
      EXPECT_GT(l.upper_floor_underside_z_m, 2.0);

      // Hills: never steeper than 15° but on the heaps, whose flanks pass 25°; the relief
      // about 3% of the side (less where the slope limit holds it back; the pad takes most of
      // the smallest sites).
      const double step = std::max(0.5, size / 300);
      double steepest = 0, steepest_heap = 0, lo = 1e9, hi = -1e9;
      for (double x = 0; x <= size; x += step) {
        for (double y = 0; y <= size; y += step) {
          const double slope = SlopeAt(l, x, y);
          if (OnHeap(l, x, y)) {
            steepest_heap = std::max(steepest_heap, slope);
            continue;
          }
          steepest = std::max(steepest, slope);
          lo = std::min(lo, l.GroundZAt(x, y));
          hi = std::max(hi, l.GroundZAt(x, y));
        }
      }
      EXPECT_LE(steepest, 15.0 * kDeg);
      EXPECT_LE(hi - lo, l.relief_m + 0.01);
      EXPECT_LE(l.relief_m, 0.03 * size + 1e-9);
      if (size >= 100) {
        EXPECT_GE(l.relief_m, 0.6 * 0.03 * size);
        EXPECT_GE(hi - lo, 0.8 * l.relief_m);
        ASSERT_FALSE(l.heaps.empty());
        EXPECT_GT(steepest_heap, 25.0 * kDeg);
      }
      // About one heap per 140 m × 140 m where they fit, none near the pad.
      if (size >= 400) EXPECT_GE(l.heaps.size(), 0.5 * size * size / (140.0 * 140.0));
      for (const auto& h : l.heaps) {
        EXPECT_FALSE(l.OnPad(h.x_m, h.y_m));
        EXPECT_GT(std::atan(1.717 * h.height_m / h.radius_m), 25.0 * kDeg);
      }

      // Obstacles: more on a bigger site, off the pad and the heaps, 3 m apart, standing on
      // the ground.
      if (size >= 250) {
        const double per_km2 = 1e6 * static_cast<double>(l.obstacles.size()) / (size * size);
        EXPECT_GT(per_km2, 1000.0);
        EXPECT_LT(per_km2, 2500.0);
      }
      for (std::size_t i = 0; i < l.obstacles.size(); ++i) {
        const auto& o = l.obstacles[i];
        EXPECT_GE(o.lo_m.x(), 0.0);
        EXPECT_LE(o.hi_m.x(), size);
        EXPECT_GE(o.lo_m.y(), 0.0);
        EXPECT_LE(o.hi_m.y(), size);
        for (const double x : {o.lo_m.x(), o.hi_m.x()}) {
          for (const double y : {o.lo_m.y(), o.hi_m.y()}) {
            EXPECT_FALSE(l.OnPad(x, y));
            EXPECT_FALSE(OnHeap(l, x, y));
            EXPECT_LT(o.lo_m.z(), l.GroundZAt(x, y));
            EXPECT_GT(o.hi_m.z(), l.GroundZAt(x, y) + 0.29);  // At least a wall's 1.2 m.
          }
        }
        if (size > 400) continue;  // Pairs: quadratic.
        for (std::size_t j = i + 1; j < l.obstacles.size(); ++j) {
          const auto& p = l.obstacles[j];
          const double gap_x = std::max(p.lo_m.x() - o.hi_m.x(), o.lo_m.x() - p.hi_m.x());
          const double gap_y = std::max(p.lo_m.y() - o.hi_m.y(), o.lo_m.y() - p.hi_m.y());
          EXPECT_GE(std::max(gap_x, gap_y), 3.0 - 1e-9);
        }
      }

      // Queries: ends on the ground, the deck or the upper floor.
      ASSERT_EQ(l.queries.size(), 4u);
      for (const SceneQuery& q : l.queries) {
        EXPECT_NEAR(q.start_m.z(), l.GroundZAt(q.start_m.x(), q.start_m.y()), 1e-9) << q.name;
      }
      EXPECT_NEAR(l.queries[0].goal_m.z(),
                  l.GroundZAt(l.queries[0].goal_m.x(), l.queries[0].goal_m.y()), 1e-9);
      EXPECT_GT((l.queries[0].goal_m - l.queries[0].start_m).head<2>().norm(), 0.9 * size);
      EXPECT_DOUBLE_EQ(l.queries[1].goal_m.z(), l.bridge_deck_z_m);
      EXPECT_DOUBLE_EQ(l.queries[3].goal_m.z(), l.upper_floor_z_m);
      EXPECT_TRUE(l.HasUpperFloor(l.queries[3].goal_m.x(), l.queries[3].goal_m.y()));
    }
  }
}

TEST(OutdoorSiteTest, OnlyVisibleFacesAreSampled) {
  const OutdoorSiteLayout l = GetOutdoorSiteLayout(2, 100.0);
  const PointCloud cloud = GenerateOutdoorSite(2, 100.0, 0.1);
  ASSERT_FALSE(l.obstacles.empty());
  constexpr double kInsetM = 0.05;
  const auto strictly_in = [&](const Eigen::Vector3f& p, double x0, double x1, double y0,
                               double y1) {
    return p.x() > x0 + kInsetM && p.x() < x1 - kInsetM && p.y() > y0 + kInsetM &&
           p.y() < y1 - kInsetM;
  };
  std::size_t obstacle_tops = 0, ramp_tops = 0, road = 0;
  for (const Eigen::Vector3f& p : cloud) {
    // Inside a box's footprint only its top: not the ground under it.
    for (const auto& o : l.obstacles) {
      if (!strictly_in(p, o.lo_m.x(), o.hi_m.x(), o.lo_m.y(), o.hi_m.y())) continue;
      ASSERT_NEAR(p.z(), o.hi_m.z(), 0.01) << p.transpose();
      ++obstacle_tops;
    }
    // Over a solid ramp only its top (and the building's upper floor does not cover it).
    for (const SceneRamp* r : {&l.bridge_ramps[0], &l.bridge_ramps[1], &l.building_ramp}) {
      if (!strictly_in(p, r->x_min_m, r->x_max_m, r->y_min_m, r->y_max_m)) continue;
      if (r == &l.building_ramp && p.z() > l.roof_underside_z_m - 0.01) continue;  // The roof.
      ASSERT_NEAR(p.z(), r->TopZAt(p.x(), p.y()), 0.01) << p.transpose();
      ++ramp_tops;
    }
    road += strictly_in(p, l.road_x_min_m, l.road_x_max_m, l.bridge_y_min_m, l.bridge_y_max_m) &&
            std::abs(p.z()) < 0.01;
  }
  EXPECT_GT(obstacle_tops, 100u);
  EXPECT_GT(ramp_tops, 1000u);
  EXPECT_GT(road, 1000u);  // The road under the span is open ground.
}

TEST(OutdoorSiteAssessed, LevelsQueriesAndSteepHeaps) {
  const std::uint32_t seed = 1;
  const OutdoorSiteLayout l = GetOutdoorSiteLayout(seed, 100.0);
  const PlanningMap map(Assess(GenerateOutdoorSite(seed, 100.0, 0.1), l.assessment_resolution_m));
  const TerrainModel& model = map.model();
  // The road under the deck and the deck; the ground floor and the upper floor.
  const double road_x = 0.5 * (l.road_x_min_m + l.road_x_max_m);
  const double deck_y = 0.5 * (l.bridge_y_min_m + l.bridge_y_max_m);
  EXPECT_TRUE(HasValidLevelNear(model, road_x, deck_y, 0.0));
  EXPECT_TRUE(HasValidLevelNear(model, road_x, deck_y, l.bridge_deck_z_m));
  const double room_x = l.building_x_max_m - 3.0, room_y = l.building_y_min_m + 3.0;
  EXPECT_TRUE(HasValidLevelNear(model, room_x, room_y, l.ground_floor_z_m));
  EXPECT_TRUE(HasValidLevelNear(model, room_x, room_y, l.upper_floor_z_m));

  for (const SceneQuery& q : l.queries) {
    const Expected<PlanResult> plan = ExpectPlans(map, q, q.robot);
    if (!plan.ok() || q.name != "ground_to_upper_floor") continue;
    // Up a storey: the climb happens on the ramp, after the west door.
    const Trajectory& t = plan->trajectory;
    bool through_door = false;
    for (double time = 0; time <= t.TotalDuration(); time += 0.1) {
      const Eigen::Vector3d p = t.Position(time).head<3>();
      const double ground = p.z() - 0.3;
      if (std::abs(p.x() - l.building_x_min_m) < 0.3) {
        through_door |= p.y() > l.west_door.from_m && p.y() < l.west_door.to_m;
      }
      if (ground < 0.2 || std::abs(ground - l.upper_floor_z_m) < 0.2) continue;
      const SceneRamp& r = l.building_ramp;
      EXPECT_TRUE(p.x() > r.x_min_m - 0.3 && p.x() < r.x_max_m + 0.3 && p.y() > r.y_min_m - 0.3 &&
                  p.y() < r.y_max_m + 0.3)
          << p.transpose();
    }
    EXPECT_TRUE(through_door);
  }

  // The heaps' steep flanks are not traversable: beyond 25° there is hardly a graph node.
  const auto graph = map.Graph(BuiltinProfile("differential")->Traversability()).value();
  int steep_columns = 0, steep_nodes = 0;
  for (double x = 0.5; x < l.size_m; x += 0.5) {
    for (double y = 0.5; y < l.size_m; y += 0.5) {
      if (!OnHeap(l, x, y) || SlopeAt(l, x, y) < 25.0 * kDeg) continue;
      ++steep_columns;
      const Eigen::Vector3i c = model.grid().CellOf({x, y, 0});
      steep_nodes += !graph->ColumnNodes(c.x(), c.y()).empty();
    }
  }
  EXPECT_GT(steep_columns, 50);
  EXPECT_LT(steep_nodes, steep_columns / 10);
}

}  // namespace
}  // namespace strata
