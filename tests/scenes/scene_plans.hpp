#pragma once
/// How the scene tests check a layout's example queries (header-only, test code only): assess
/// the scene, then plan each SceneQuery and expect a verified plan between the snapped ends.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "strata/planner.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "test_util/terrain_queries.hpp"

namespace strata::test_util {

inline std::shared_ptr<const TerrainModel> Assess(const PointCloud& cloud, double resolution_m) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  return TerrainModel::Assess(cloud, config).value();
}

/// Whether the column at (x, y) holds valid ground within `tol_m` of z.
inline bool HasValidLevelNear(const TerrainModel& model, double x, double y, double z,
                              double tol_m = 0.15) {
  for (const ColumnSurface& s : LevelsAt(model, {x, y, z})) {
    if (s.valid && std::abs(s.ground_z_m - z) <= tol_m) return true;
  }
  return false;
}

inline PlanRequest Request(const SceneQuery& q, const std::string& robot) {
  PlanRequest request;
  request.start.position_m = q.start_m;
  request.goal.position_m = q.goal_m;
  request.profile = BuiltinProfile(robot).value();
  // Generous: this is not a speed test, and CI machines are shared.
  request.options.time_budget_s = 30.0;
  return request;
}

/// Start and goal in one component, and a verified plan whose ends are the snapped points.
inline Expected<PlanResult> ExpectPlans(const PlanningMap& map, const SceneQuery& q,
                                        const std::string& robot) {
  SCOPED_TRACE(q.name + " (" + robot + ")");
  const PlanRequest request = Request(q, robot);
  const auto graph = map.Graph(request.profile.Traversability()).value();
  const auto start = SnapToSurface(*graph, q.start_m, 1.0, ErrorCode::kStartOffGround);
  const auto goal = SnapToSurface(*graph, q.goal_m, 1.0, ErrorCode::kGoalOffGround);
  EXPECT_TRUE(start.ok() && goal.ok());
  if (start.ok() && goal.ok()) {
    EXPECT_EQ(graph->component(start->node), graph->component(goal->node));
    EXPECT_NEAR(start->position_m.z() - request.profile.reference_height_m, q.start_m.z(), 0.15);
    EXPECT_NEAR(goal->position_m.z() - request.profile.reference_height_m, q.goal_m.z(), 0.15);
  }
  Expected<PlanResult> plan = Plan(map, request);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  if (!plan.ok()) return plan;
  const Trajectory& t = plan->trajectory;
  EXPECT_LT((t.Position(0).head<2>() - plan->start.position_m.head<2>()).norm(), 0.5);
  EXPECT_LT((t.Position(t.TotalDuration()).head<2>() - plan->goal.position_m.head<2>()).norm(),
            0.5);
  EXPECT_LE(plan->stats.max_ground_offset_m, request.options.verifier.ground_tolerance_m);
  EXPECT_LE(plan->stats.max_speed_horizontal_mps, 1.01 * request.profile.max_speed_horizontal_mps);
  EXPECT_LE(plan->stats.max_tilt_rad, request.profile.max_tilt_rad + 1e-6);
  EXPECT_GE(
      plan->stats.min_headroom_m,
      request.profile.headroom_m - BodyHeightTolerance(request.profile, request.options.verifier));
  return plan;
}

}  // namespace strata::test_util
