// The paper's scenes (strata/scenes/paper_scenes.hpp): determinism, bounds and sizes, the layouts'
// promises, and, after terrain assessment, their levels, their example queries (reachable and
// planned) and what must not be traversable. One assessment per scene, each well under a
// second on two cores.
#include "strata/scenes/paper_scenes.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "scenes/scene_plans.hpp"
#include "strata/planner.hpp"
#include "strata/scenes/scenes.hpp"
#include "test_util/terrain_queries.hpp"

namespace strata {
namespace {

using test_util::Assess;
using test_util::ExpectPlans;
using test_util::HasValidLevelNear;
using test_util::Request;

constexpr double kMaxJitterZM = 0.005;
constexpr double kFloatSlackM = 1e-4;
// Upper bound on any of these scenes at its default spacing, so assessment stays around a
// second (paper_scenes.hpp gives each scene's own figure).
constexpr std::size_t kMaxPoints = 400'000;

struct BenchScene {
  std::string name;
  std::function<PointCloud(std::uint32_t, double)> generate;
  double default_spacing_m;
  Eigen::Vector3d lo_m, hi_m;  // Documented bounds (before jitter).
};

std::vector<BenchScene> Scenes() {
  const ViaductsLayout v = GetViaductsLayout();
  const StationLayout st = GetStationLayout();
  const GarageLayout g = GetGarageLayout();
  const IndoorTablesLayout t = GetIndoorTablesLayout();
  return {
      {"uneven_forest", GenerateUnevenForest, 0.1, {0, 0, -10}, {40, 40, 20}},
      {"abandoned_station",
       GenerateAbandonedStation,
       0.1,
       {0, 0, 0},
       {st.x_max_m, st.y_max_m, st.mezzanine_z_m + st.railing_height_m}},
      {"parking_garage",
       GenerateParkingGarage,
       0.16,
       {0, 0, 0},
       {g.x_max_m, g.y_max_m, g.level_z_m.back() + 1.4}},  // Cars parked on the roof.
      {"crossing_viaducts",
       GenerateCrossingViaducts,
       0.16,
       {0, 0, 0},
       {v.size_m, v.size_m, v.b_z_m + v.railing_height_m}},
      {"indoor_tables",
       GenerateIndoorTables,
       0.05,
       {0, 0, 0},
       {t.x_max_m, t.y_max_m, t.wall_height_m}},
  };
}

TEST(BenchScenesTest, SameSeedSameCloudOtherSeedOtherCloud) {
  for (const BenchScene& scene : Scenes()) {
    SCOPED_TRACE(scene.name);
    const PointCloud a = scene.generate(7, scene.default_spacing_m);
    ASSERT_FALSE(a.empty());
    EXPECT_TRUE(a == scene.generate(7, scene.default_spacing_m));
    EXPECT_FALSE(a == scene.generate(8, scene.default_spacing_m));
  }
}

TEST(BenchScenesTest, ByNameAtTheDefaultSpacingWithinBoundsAndSize) {
  const std::vector<std::string> names = SceneNames();
  for (const BenchScene& scene : Scenes()) {
    SCOPED_TRACE(scene.name);
    EXPECT_NE(std::find(names.begin(), names.end(), scene.name), names.end());
    EXPECT_DOUBLE_EQ(ResolveSceneOptions(scene.name, {})->spacing_m.value(),
                     scene.default_spacing_m);
    const Expected<PointCloud> cloud = GenerateScene(scene.name, 3);
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    EXPECT_TRUE(*cloud == scene.generate(3, scene.default_spacing_m));
    EXPECT_GT(cloud->size(), 50'000u);
    EXPECT_LE(cloud->size(), kMaxPoints);
    const double txy = 0.1 * scene.default_spacing_m + kFloatSlackM;
    const double tz = kMaxJitterZM + kFloatSlackM;
    for (const Eigen::Vector3f& p : *cloud) {
      ASSERT_TRUE(p.allFinite());
      ASSERT_TRUE(p.x() >= scene.lo_m.x() - txy && p.x() <= scene.hi_m.x() + txy &&
                  p.y() >= scene.lo_m.y() - txy && p.y() <= scene.hi_m.y() + txy &&
                  p.z() >= scene.lo_m.z() - tz && p.z() <= scene.hi_m.z() + tz)
          << "point (" << p.transpose() << ") outside the documented bounds";
    }
    // A coarser spacing gives fewer points; an invalid one none.
    EXPECT_LT(scene.generate(3, 2 * scene.default_spacing_m).size(), cloud->size() / 3);
    EXPECT_TRUE(scene.generate(3, 0.001).empty());
  }
  const Expected<PointCloud> bad = GenerateScene("indoor_tables", 1, {.spacing_m = std::nan("")});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(bad.error().message, ::testing::HasSubstr("spacing_m"));
}

TEST(BenchScenesTest, RampsAreGentleAndWide) {
  std::vector<SceneRamp> ramps;
  const StationLayout st = GetStationLayout();
  const GarageLayout g = GetGarageLayout();
  const ViaductsLayout v = GetViaductsLayout();
  for (const auto* list :
       {&st.track_ramps, &st.mezzanine_ramps, &g.ramps, &v.a_ramps, &v.b_ramps}) {
    ramps.insert(ramps.end(), list->begin(), list->end());
  }
  for (const SceneRamp& r : ramps) {
    EXPECT_LE(r.SlopeRad(), 12.0 * std::numbers::pi / 180 + 1e-9);
    EXPECT_GE(r.Width(), 3.0);
    EXPECT_NEAR(r.uphill_dir.norm(), 1.0, 1e-12);
    EXPECT_NEAR(r.TopZAt(r.x_min_m, r.y_min_m) + r.TopZAt(r.x_max_m, r.y_max_m),
                r.z_low_m + r.z_high_m, 1e-9);  // One end at each height.
  }
}

TEST(BenchScenesTest, ForestLayoutMeetsTheDescription) {
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const UnevenForestLayout f = GetUnevenForestLayout(seed);
    const UnevenTerrainLayout& t = f.terrain;
    EXPECT_DOUBLE_EQ(t.size_m, 40.0);
    EXPECT_GE(t.trees.size(), 28u);
    EXPECT_LE(t.trees.size(), 38u);
    EXPECT_GE(t.rocks.size(), 16u);
    EXPECT_LE(t.rocks.size(), 22u);
    EXPECT_GE(f.logs.size(), 8u);
    EXPECT_LE(f.logs.size(), 12u);
    for (const auto& log : f.logs) {
      EXPECT_GE(log.radius_m, 0.15);
      EXPECT_LE(log.radius_m, 0.3);
      const double length = (log.b_m - log.a_m).head<2>().norm();
      EXPECT_GE(length, 3.0 - 1e-9);
      EXPECT_LE(length, 6.0 + 1e-9);
      // Lying on the ground, sunk by a fifth of its radius at both ends.
      for (const Eigen::Vector3d& end : {log.a_m, log.b_m}) {
        EXPECT_NEAR(end.z() - t.HeightAt(end.x(), end.y()), 0.8 * log.radius_m, 1e-9);
      }
    }
    // Slopes from gentle to beyond the robot's 20°.
    double max_slope = 0;
    for (double x = 0; x <= t.size_m; x += 0.25) {
      for (double y = 0; y <= t.size_m; y += 0.25) {
        max_slope = std::max(max_slope, std::atan(t.GradientAt(x, y).norm()));
      }
    }
    EXPECT_GT(max_slope, 30.0 * std::numbers::pi / 180);
    ASSERT_EQ(f.queries.size(), 3u);
    for (const SceneQuery& q : f.queries) {
      EXPECT_NEAR(q.start_m.z(), t.HeightAt(q.start_m.x(), q.start_m.y()), 1e-9);
      EXPECT_NEAR(q.goal_m.z(), t.HeightAt(q.goal_m.x(), q.goal_m.y()), 1e-9);
      EXPECT_GT((q.goal_m - q.start_m).head<2>().norm(), 25.0) << q.name;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Assessed scenes.

TEST(BenchScenesAssessed, ForestQueriesPlanAroundTreesRocksLogsAndSteepHills) {
  // One seed keeps the test short; the queries of seeds 2–8 plan too (checked by hand with
  // strata-offline plan, docs/scenes.md).
  for (const std::uint32_t seed : {1u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const UnevenForestLayout f = GetUnevenForestLayout(seed);
    const PlanningMap map(Assess(GenerateUnevenForest(seed), f.assessment_resolution_m));
    // Steep flanks are not traversable: somewhere beyond 25° there is no graph node.
    const auto graph = map.Graph(BuiltinProfile("differential")->Traversability()).value();
    int steep_columns = 0, steep_nodes = 0;
    for (double x = 1; x < 39; x += 0.5) {
      for (double y = 1; y < 39; y += 0.5) {
        if (std::atan(f.terrain.GradientAt(x, y).norm()) < 25.0 * std::numbers::pi / 180) continue;
        ++steep_columns;
        const Eigen::Vector3i c = map.model().grid().CellOf({x, y, 0});
        steep_nodes += !graph->ColumnNodes(c.x(), c.y()).empty();
      }
    }
    EXPECT_GT(steep_columns, 50);
    EXPECT_LT(steep_nodes, steep_columns / 10);
    for (const SceneQuery& q : f.queries) {
      EXPECT_TRUE(HasValidLevelNear(map.model(), q.start_m.x(), q.start_m.y(), q.start_m.z()));
      (void)ExpectPlans(map, q, q.robot);
    }
  }
}

TEST(BenchScenesAssessed, StationLevelsQueriesAndTheCollapseIsNotTraversable) {
  const StationLayout l = GetStationLayout();
  const PlanningMap map(Assess(GenerateAbandonedStation(4), l.assessment_resolution_m));
  const TerrainModel& model = map.model();
  // Three levels; the mezzanine overhangs the platform.
  EXPECT_TRUE(HasValidLevelNear(model, 30.0, 4.0, l.track_z_m));
  EXPECT_TRUE(HasValidLevelNear(model, 30.0, 10.0, l.platform_z_m));
  for (const double x : {12.0, 38.0}) {
    EXPECT_TRUE(HasValidLevelNear(model, x, 21.5, l.platform_z_m)) << x;
    EXPECT_TRUE(HasValidLevelNear(model, x, 21.5, l.mezzanine_z_m)) << x;
  }
  for (const SceneQuery& q : l.queries) {
    const Expected<PlanResult> plan = ExpectPlans(map, q, q.robot);
    if (!plan.ok() || q.name != "mezzanine_west_to_east") continue;
    // The direct way is cut: the trajectory goes down to the platform and never over the
    // collapse.
    const Trajectory& t = plan->trajectory;
    double lowest = 1e9;
    for (double time = 0; time <= t.TotalDuration(); time += 0.1) {
      const Eigen::Vector3d p = t.Position(time).head<3>();
      lowest = std::min(lowest, p.z());
      EXPECT_FALSE(l.InCollapse(p.x(), p.y())) << p.transpose();
    }
    EXPECT_LT(lowest, l.platform_z_m + 0.5);
  }
  // No node of the map's main component lies in the collapsed section (the rubble's tops may
  // be tiny islands of their own).
  const auto graph = map.Graph(BuiltinProfile("differential")->Traversability()).value();
  const auto main_node =
      SnapToSurface(*graph, l.queries[0].start_m, 1.0, ErrorCode::kStartOffGround).value().node;
  int collapse_nodes_in_main = 0, collapse_columns = 0;
  for (double x = l.collapse_x_min_m + 0.3; x < l.collapse_x_max_m - 0.3; x += 0.2) {
    for (double y = l.collapse_y_min_m + 0.3; y < l.collapse_y_max_m - 0.3; y += 0.2) {
      ++collapse_columns;
      const Eigen::Vector3i c = model.grid().CellOf({x, y, 0});
      for (const int m : graph->ColumnNodes(c.x(), c.y())) {
        collapse_nodes_in_main += graph->component(m) == graph->component(main_node);
      }
    }
  }
  EXPECT_GT(collapse_columns, 100);
  EXPECT_EQ(collapse_nodes_in_main, 0);
}

TEST(BenchScenesAssessed, GarageDecksAndQueriesThroughTheRamps) {
  const GarageLayout l = GetGarageLayout();
  const PlanningMap map(Assess(GenerateParkingGarage(4), l.assessment_resolution_m));
  // Every level at a place in the central aisle, on top of each other.
  for (const double z : l.level_z_m) EXPECT_TRUE(HasValidLevelNear(map.model(), 6.0, 14.9, z)) << z;
  // Storeys low enough that the decks are 2.8 m apart with under 2.6 m clear.
  for (std::size_t k = 0; k + 1 < l.level_z_m.size(); ++k) {
    EXPECT_NEAR(l.level_z_m[k + 1] - l.level_z_m[k], 2.8, 1e-12);
  }
  for (const SceneQuery& q : l.queries) {
    const Expected<PlanResult> plan = ExpectPlans(map, q, q.robot);
    if (!plan.ok() || q.name != "ground_to_roof") continue;
    // Up three storeys: the climb happens on the ramps' footprints.
    const Trajectory& t = plan->trajectory;
    for (double time = 0; time <= t.TotalDuration(); time += 0.2) {
      const Eigen::Vector3d p = t.Position(time).head<3>();
      const double ground = p.z() - 0.3;
      const bool at_level = std::any_of(l.level_z_m.begin(), l.level_z_m.end(),
                                        [&](double z) { return std::abs(ground - z) < 0.2; });
      if (at_level) continue;
      const bool on_ramp = std::any_of(l.ramps.begin(), l.ramps.end(), [&](const SceneRamp& r) {
        return p.x() > r.x_min_m - 0.3 && p.x() < r.x_max_m + 0.3 && p.y() > r.y_min_m - 0.3 &&
               p.y() < r.y_max_m + 0.3;
      });
      EXPECT_TRUE(on_ramp) << p.transpose();
    }
  }
}

TEST(BenchScenesAssessed, ViaductsCrossAtTwoHeightsOverTheRoad) {
  const ViaductsLayout l = GetViaductsLayout();
  const PlanningMap map(Assess(GenerateCrossingViaducts(4), l.assessment_resolution_m));
  // At the crossing: the road, viaduct A and viaduct B above each other.
  const double c = 0.5 * l.size_m;
  EXPECT_TRUE(HasValidLevelNear(map.model(), c, c - 0.6, 0.0));
  EXPECT_TRUE(HasValidLevelNear(map.model(), c, c - 0.6, l.a_z_m));
  EXPECT_TRUE(HasValidLevelNear(map.model(), c, c - 0.6, l.b_z_m));
  EXPECT_NEAR(l.AZAt(c, c), l.a_z_m, 1e-12);
  EXPECT_NEAR(l.BZAt(c, c), l.b_z_m, 1e-12);
  EXPECT_GT(l.b_z_m - l.deck_thickness_m - l.a_z_m, 2.0);  // Room to drive on A under B.
  EXPECT_LT(l.RoadDistance(c, c), 1e-9);
  for (const auto* piers : {&l.a_piers_m, &l.b_piers_m}) {
    for (const Eigen::Vector2d& p : *piers) {
      EXPECT_GT(l.RoadDistance(p.x(), p.y()), 0.5 * l.road_width_m + l.pier_radius_m + 0.5);
    }
  }
  for (const SceneQuery& q : l.queries) (void)ExpectPlans(map, q, q.robot);
}

TEST(BenchScenesAssessed, TablesOnlyTheBipedCrouchesUnderTheRow) {
  const IndoorTablesLayout l = GetIndoorTablesLayout();
  const PlanningMap map(Assess(GenerateIndoorTables(4), l.assessment_resolution_m));
  EXPECT_LT(l.table_underside_z_m, 0.5 + 0.05 + 1e-9);   // Differential: body 0.5 + headroom.
  EXPECT_GE(l.table_underside_z_m, 0.35 + 0.05 + 0.05);  // Biped: lowest body + headroom.
  for (const SceneQuery& q : l.queries) {
    const Expected<PlanResult> plan = ExpectPlans(map, q, q.robot);
    if (!l.IsBehindRow(q.goal_m.x(), q.goal_m.y())) continue;
    // Behind the row: the biped crouches under it, the differential robot cannot get there.
    ASSERT_EQ(q.robot, "biped");
    if (plan.ok()) {
      const RobotProfile biped = BuiltinProfile("biped").value();
      const double tolerance = BodyHeightTolerance(biped, VerifierConfig{});
      EXPECT_LE(plan->stats.min_body_height_m,
                l.table_underside_z_m - biped.headroom_m + tolerance);
      EXPECT_GE(plan->stats.min_headroom_m, biped.headroom_m - tolerance);
    }
    const Expected<PlanResult> wheeled = Plan(map, Request(q, "differential"));
    ASSERT_FALSE(wheeled.ok()) << q.name;
    EXPECT_EQ(wheeled.error().code, ErrorCode::kGoalUnreachable) << wheeled.error().message;
  }
}

}  // namespace
}  // namespace strata
