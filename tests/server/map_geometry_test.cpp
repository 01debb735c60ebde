// The map's geometry for display (server/rpc/map_geometry.hpp) against the model it is drawn from:
// at stride 1 every column surface comes out once, as it is; merged blocks keep each block's
// highest ground; S' and components are the model's and the graph's own.
#include "rpc/map_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <gtest/gtest.h>

#include "strata/planning/robot_profile.hpp"
#include "test_util/two_level_scene.hpp"

namespace strata::server {
namespace {

const TerrainModel& Model() { return test_util::TwoLevelScene(); }

TEST(MapGeometryTest, AtStrideOneEveryColumnSurfaceComesOutOnceAsItIs) {
  const TerrainModel& model = Model();
  const MapGeometryData data = ExtractMapGeometry(model, GeometryRequest{}).value();
  const GridGeometry& grid = model.grid();
  ASSERT_EQ(data.nx, grid.size.x());
  ASSERT_EQ(data.ny, grid.size.y());
  EXPECT_EQ(data.ground_z_m.size(), model.surfaces().valid_surface_count());
  EXPECT_EQ(data.ground_z_m.size() + data.obstacle_z_m.size(), model.surfaces().surface_count());
  EXPECT_TRUE(data.ground_safety.empty());
  EXPECT_TRUE(data.ground_component.empty());

  std::size_t g = 0, o = 0;
  int max_levels = 0;
  for (int iy = 0; iy < grid.size.y(); ++iy) {
    for (int ix = 0; ix < grid.size.x(); ++ix) {
      const auto cell = static_cast<std::uint32_t>(ix + data.nx * iy);
      int level = 0;
      for (const ColumnSurface& surface : model.surfaces().Column(ix, iy)) {
        if (surface.valid) {
          ASSERT_LT(g, data.ground_cell.size());
          EXPECT_EQ(data.ground_cell[g], cell);
          EXPECT_NEAR(data.ground_z_m[g], surface.ground_z_m, 6e-4);
          EXPECT_EQ(data.ground_level[g], static_cast<std::uint32_t>(level));
          ++level;
          ++g;
        } else {
          ASSERT_LT(o, data.obstacle_cell.size());
          EXPECT_EQ(data.obstacle_cell[o], cell);
          EXPECT_NEAR(data.obstacle_z_m[o], surface.ground_z_m, 6e-4);
          EXPECT_EQ(data.obstacle_level[o], static_cast<std::uint32_t>(std::max(0, level - 1)));
          ++o;
        }
      }
      max_levels = std::max(max_levels, level);
    }
  }
  EXPECT_EQ(data.max_levels, max_levels);
  EXPECT_GE(max_levels, 2);  // The deck over the floor.
}

TEST(MapGeometryTest, AMergedBlockKeepsItsHighestGroundAndFewerSurfaces) {
  const TerrainModel& model = Model();
  const GridGeometry& grid = model.grid();
  constexpr int kStride = 4;
  GeometryRequest request;
  request.stride = kStride;
  const MapGeometryData data = ExtractMapGeometry(model, request).value();
  EXPECT_EQ(data.nx, (grid.size.x() + kStride - 1) / kStride);
  EXPECT_LT(data.ground_z_m.size(), model.surfaces().valid_surface_count() / 4);

  // Highest ground per display cell, from the model and from the data.
  std::map<std::uint32_t, float> expected, got;
  for (int iy = 0; iy < grid.size.y(); ++iy) {
    for (int ix = 0; ix < grid.size.x(); ++ix) {
      const auto cell = static_cast<std::uint32_t>(ix / kStride + data.nx * (iy / kStride));
      for (const ColumnSurface& surface : model.surfaces().Column(ix, iy)) {
        if (!surface.valid) continue;
        auto [it, fresh] = expected.emplace(cell, surface.ground_z_m);
        if (!fresh) it->second = std::max(it->second, surface.ground_z_m);
      }
    }
  }
  for (std::size_t i = 0; i < data.ground_cell.size(); ++i) {
    if (i > 0) ASSERT_LE(data.ground_cell[i - 1], data.ground_cell[i]) << "not ordered by cell";
    auto [it, fresh] = got.emplace(data.ground_cell[i], data.ground_z_m[i]);
    if (!fresh) {
      EXPECT_GT(data.ground_z_m[i], it->second + kMergeGapM) << "levels of a cell not apart";
      it->second = data.ground_z_m[i];
    }
  }
  ASSERT_EQ(got.size(), expected.size());
  for (const auto& [cell, z] : expected) EXPECT_NEAR(got.at(cell), z, 6e-4) << "cell " << cell;
}

TEST(MapGeometryTest, SafetyIsTheFieldAtTheReferenceHeightAndComponentsAreTheGraphs) {
  const TerrainModel& model = Model();
  const RobotProfile profile = BuiltinProfile("differential").value();
  const SurfaceGraph graph = SurfaceGraph::Build(model, profile.Traversability()).value();
  GeometryRequest request;
  request.include_safety = true;
  request.safety_height_m = profile.reference_height_m;
  request.graph = &graph;
  const MapGeometryData data = ExtractMapGeometry(model, request).value();
  ASSERT_EQ(data.ground_safety.size(), data.ground_z_m.size());
  ASSERT_EQ(data.ground_component.size(), data.ground_z_m.size());
  const GridGeometry& grid = model.grid();
  int traversable = 0;
  for (std::size_t i = 0; i < data.ground_cell.size(); ++i) {
    const int ix = static_cast<int>(data.ground_cell[i]) % data.nx;
    const int iy = static_cast<int>(data.ground_cell[i]) / data.nx;
    // S' at the surface's own height (the data's is rounded to the millimetre, and S' is
    // steep by walls).
    float ground_z = std::numeric_limits<float>::quiet_NaN();
    for (const ColumnSurface& surface : model.surfaces().Column(ix, iy)) {
      if (surface.valid && std::abs(surface.ground_z_m - data.ground_z_m[i]) < 1e-3) {
        ground_z = surface.ground_z_m;
      }
    }
    ASSERT_FALSE(std::isnan(ground_z))
        << "no valid surface of the column at " << data.ground_z_m[i];
    const Eigen::Vector3d centre = grid.CellCenter({ix, iy, 0});
    const double expected =
        model.SafetyPenalty({centre.x(), centre.y(), ground_z + profile.reference_height_m});
    EXPECT_NEAR(data.ground_safety[i], expected, 6e-4);
    // The node standing on this surface, if the robot can stand there.
    int node = -1;
    for (const std::int32_t m : graph.ColumnNodes(ix, iy)) {
      if (std::abs(graph.ground_z(m) - data.ground_z_m[i]) < 2e-3) node = m;
    }
    EXPECT_EQ(data.ground_component[i], node >= 0 ? graph.component(node) : -1);
    traversable += node >= 0 ? 1 : 0;
  }
  EXPECT_EQ(traversable, graph.node_count());
}

TEST(MapGeometryTest, BadRequestsAndStopping) {
  const TerrainModel& model = Model();
  GeometryRequest request;
  request.stride = 0;
  EXPECT_EQ(ExtractMapGeometry(model, request).error().field, "stride");
  request.stride = kMaxGeometryStride + 1;
  EXPECT_EQ(ExtractMapGeometry(model, request).error().code, ErrorCode::kInvalidConfig);
  request.stride = 1;
  EXPECT_EQ(ExtractMapGeometry(model, request, [] { return true; }).error().code,
            ErrorCode::kCancelled);
}

TEST(MapGeometryTest, TheEstimatedStrideGrowsAsTheBytesShrink) {
  const TerrainModel& model = Model();
  const std::size_t surfaces = model.surfaces().surface_count();
  EXPECT_EQ(EstimateGeometryStride(model, surfaces * 10, 10.0), 1);
  EXPECT_EQ(EstimateGeometryStride(model, (surfaces * 10 + 3) / 4, 10.0), 2);
  EXPECT_EQ(EstimateGeometryStride(model, (surfaces * 10 + 8) / 9, 10.0), 3);
  EXPECT_EQ(EstimateGeometryStride(model, surfaces * 10 / 9 - 1, 10.0), 4);
  EXPECT_EQ(EstimateGeometryStride(model, 1, 10.0), kMaxGeometryStride);
}

}  // namespace
}  // namespace strata::server
