#include "strata/assessment/terrain_model.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <optional>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "assessment/terrain_model_internal.hpp"
#include "strata/assessment/ground_filter.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/terrain_queries.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

class TwoLevelModel : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    auto model = TerrainModel::Assess(GenerateTwoLevelRamp(/*seed=*/5), config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    model_ = new std::shared_ptr<const TerrainModel>(*model);
  }
  static void TearDownTestSuite() { delete model_; }
  const TerrainModel& model() const { return **model_; }

  static std::shared_ptr<const TerrainModel>* model_;
  TwoLevelRampLayout layout_ = GetTwoLevelRampLayout();
};
std::shared_ptr<const TerrainModel>* TwoLevelModel::model_ = nullptr;

TEST_F(TwoLevelModel, ColumnUnderTheDeckHasTwoValidLevels) {
  const Eigen::Vector3d goal = layout_.goal_example_m;
  std::vector<double> valid_heights;
  for (const ColumnSurface& s : test_util::LevelsAt(model(), goal)) {
    if (s.valid) valid_heights.push_back(s.ground_z_m);
  }
  ASSERT_EQ(valid_heights.size(), 2u);
  EXPECT_NEAR(valid_heights[0], layout_.floor_z_m, 0.02);
  EXPECT_NEAR(valid_heights[1], layout_.deck_z_m, 0.02);
}

TEST_F(TwoLevelModel, GroundBelowDependsOnTheLevelThePointIsOn) {
  Eigen::Vector3d p = layout_.goal_example_m;
  p.z() = layout_.floor_z_m + 1.0;  // Under the deck.
  ASSERT_TRUE(test_util::GroundHeightBelow(model(), p).has_value());
  EXPECT_NEAR(*test_util::GroundHeightBelow(model(), p), layout_.floor_z_m, 0.02);
  p.z() = layout_.deck_z_m + 0.5;  // On the deck.
  ASSERT_TRUE(test_util::GroundHeightBelow(model(), p).has_value());
  EXPECT_NEAR(*test_util::GroundHeightBelow(model(), p), layout_.deck_z_m, 0.02);
  const ColumnSurface* floor =
      test_util::SurfaceBelow(model(), {p.x(), p.y(), layout_.floor_z_m + 1.0});
  ASSERT_NE(floor, nullptr);
  // Clearance under the deck: up to the slab's underside.
  EXPECT_NEAR(floor->clearance_m, layout_.deck_underside_z_m - layout_.floor_z_m, 0.06);
}

// Where a robot can stand is where its SurfaceGraph has a node (the one definition).
TEST_F(TwoLevelModel, TraversabilityRespectsBodyHeightAndLevels) {
  const GridGeometry& g = model().grid();
  TraversabilityParams short_body;
  short_body.reference_height_m = 0.3;
  short_body.body_height_m = 1.0;
  TraversabilityParams tall_body = short_body;
  tall_body.body_height_m = 3.5;
  const Expected<SurfaceGraph> short_graph = SurfaceGraph::Build(model(), short_body);
  const Expected<SurfaceGraph> tall_graph = SurfaceGraph::Build(model(), tall_body);
  ASSERT_TRUE(short_graph.ok()) << short_graph.error().message;
  ASSERT_TRUE(tall_graph.ok()) << tall_graph.error().message;

  Eigen::Vector3d under_deck = layout_.goal_example_m;
  under_deck.z() = layout_.floor_z_m + short_body.reference_height_m;
  EXPECT_TRUE(test_util::HasNodeInCell(*short_graph, g.CellOf(under_deck)));
  // A body taller than the room under the deck does not fit.
  EXPECT_FALSE(test_util::HasNodeInCell(*tall_graph, g.CellOf(under_deck)));
  Eigen::Vector3d on_deck = layout_.goal_example_m;
  on_deck.z() = layout_.deck_z_m + tall_body.reference_height_m;
  EXPECT_TRUE(test_util::HasNodeInCell(*tall_graph, g.CellOf(on_deck)));
  // Floating between the levels is not standing anywhere.
  Eigen::Vector3d mid_air = layout_.goal_example_m;
  mid_air.z() = 1.5;
  EXPECT_FALSE(test_util::HasNodeInCell(*short_graph, g.CellOf(mid_air)));
}

TEST_F(TwoLevelModel, RampIsValidGroundAndWallsAreNot) {
  const double mid_x = 0.5 * (layout_.ramp_x_min_m + layout_.ramp_x_max_m);
  const double mid_y = 0.5 * (layout_.ramp_y_min_m + layout_.ramp_y_max_m);
  const double ramp_z =
      layout_.floor_z_m + (mid_x - layout_.ramp_x_min_m) * std::tan(layout_.ramp_slope_rad);
  const auto ground = test_util::GroundHeightBelow(model(), {mid_x, mid_y, ramp_z + 0.3});
  ASSERT_TRUE(ground.has_value());
  EXPECT_NEAR(*ground, ramp_z, 0.05);
  const ColumnSurface* ramp = test_util::SurfaceBelow(model(), {mid_x, mid_y, ramp_z + 0.3});
  EXPECT_NEAR(ramp->tilt_rad, layout_.ramp_slope_rad, 0.5 * M_PI / 180);

  // Next to the outer wall (x = 0) the floor is not valid within the filter radius.
  const auto by_wall = test_util::GroundHeightBelow(model(), {0.05, 3.0, 0.3});
  EXPECT_FALSE(by_wall.has_value());
}

TEST_F(TwoLevelModel, DistanceFieldKnowsWhereTheDeckIs) {
  // 0.3 m above the deck's top, the nearest obstacle is the deck itself.
  Eigen::Vector3d p = layout_.goal_example_m;
  p.z() = layout_.deck_z_m + 0.3;
  Eigen::Vector3d gradient;
  const double d = model().Distance(p, &gradient);
  EXPECT_NEAR(d, 0.3, 0.1);
  EXPECT_GT(gradient.z(), 0.5);  // Moving up leaves the slab.
  // 2.3 m above the floor under the deck is outside the band the planner reads: the field
  // reads its background there, the distance cap.
  p.z() = layout_.deck_underside_z_m - 0.5;
  EXPECT_EQ(model().Distance(p, &gradient), model().config().grid.distance_cap_m);
  EXPECT_EQ(gradient, Eigen::Vector3d::Zero());
}

TEST_F(TwoLevelModel, ReportsSummaryAndMemory) {
  const AssessmentSummary& s = model().summary();
  EXPECT_GT(s.valid_ground_points, s.input_points / 3);
  EXPECT_LT(s.valid_ground_points, s.input_points);
  EXPECT_GT(s.valid_surface_count, 0u);
  EXPECT_GT(s.timings.total_s, 0.0);
  EXPECT_GE(s.timings.total_s,
            s.timings.ground_filter_s + s.timings.surfaces_s + s.timings.fields_s - 1e-9);
  // The fields hold the band (band height / r + 3 layers) around each valid surface, a few
  // more where a neighbour's ground differs, two 16-bit values per cell; every column also
  // costs a few bytes of index (terrain_fields_test checks that the volume costs nothing).
  const TerrainFields& fields = model().fields();
  const auto columns = static_cast<std::size_t>(model().grid().LayerCellCount());
  const std::size_t chunks = fields.chunks().size();
  std::size_t runs = 0;
  for (const TerrainFields::Chunk& chunk : fields.chunks()) runs += chunk->intervals.size();
  EXPECT_EQ(fields.MemoryBytes(), chunks * sizeof(TerrainFields::Chunk) + (columns + chunks) * 4 +
                                      runs * 8 + fields.cell_count() * 4);
  const double layers = model().config().grid.band_height_m / model().grid().resolution_m + 3;
  EXPECT_LT(static_cast<double>(fields.cell_count()), 1.5 * layers * s.valid_surface_count);
  EXPECT_GT(static_cast<double>(fields.cell_count()), layers * s.valid_surface_count);
}

TEST(TerrainModel, RefusesAnEmptyCloud) {
  auto model = TerrainModel::Assess({}, AssessmentConfig{});
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().code, ErrorCode::kInvalidInput);
}

TEST(TerrainModel, RefusesAnInvalidConfigNamingTheField) {
  AssessmentConfig config;
  config.grid.resolution_m = 0;
  auto model = TerrainModel::Assess({{0, 0, 0}}, config);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(model.error().message, HasSubstr("grid.resolution_m"));
}

TEST(TerrainModel, RefusesAGridOfTerabytes) {
  // Two points 50 km apart: at 0.1 m the grid would have ~10^14 cells.
  auto model = TerrainModel::Assess({{0, 0, 0}, {5.0e4f, 5.0e4f, 10.0f}}, [] {
    AssessmentConfig c;
    c.grid.resolution_m = 0.1;
    return c;
  }());
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().code, ErrorCode::kResourceExhausted);
}

// The shared reference maps: valid ground is the floors and ramps, not walls.
class SharedMap : public ::testing::TestWithParam<const char*> {};

TEST_P(SharedMap, AssessesWithSensibleNumbers) {
  const std::string path = std::string(STRATA_SHARED_MAPS_DIR) + "/" + GetParam();
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent; shared maps not found";
  auto cloud = LoadPointCloud(path);
  ASSERT_TRUE(cloud.ok()) << cloud.error().message;
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  auto model = TerrainModel::Assess(cloud->points, config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const TerrainModel& m = **model;
  const AssessmentSummary& s = m.summary();
  EXPECT_GT(s.valid_ground_points, s.input_points / 4);
  EXPECT_LT(s.valid_ground_points, s.input_points);
  // Inside floors and ramps (valid ground with valid ground of similar height in all four
  // neighbouring columns) the fitted planes are level enough to stand on. Edges, and the
  // tops of the spiral's 1 m rails, which are valid but narrow, may read steep.
  const auto has_neighbour_near = [&](int ix, int iy, float z) {
    for (const ColumnSurface& s : m.surfaces().Column(ix, iy)) {
      if (s.valid && std::abs(s.ground_z_m - z) <= 0.25f) return true;
    }
    return false;
  };
  int steep = 0;
  int interior = 0;
  const GridGeometry& g = m.grid();
  for (int iy = 1; iy + 1 < g.size.y(); ++iy) {
    for (int ix = 1; ix + 1 < g.size.x(); ++ix) {
      for (const ColumnSurface& surface : m.surfaces().Column(ix, iy)) {
        const float z = surface.ground_z_m;
        if (!surface.valid || !has_neighbour_near(ix - 1, iy, z) ||
            !has_neighbour_near(ix + 1, iy, z) || !has_neighbour_near(ix, iy - 1, z) ||
            !has_neighbour_near(ix, iy + 1, z)) {
          continue;
        }
        ++interior;
        steep += surface.tilt_rad > config.ground.max_tilt_rad;
      }
    }
  }
  ASSERT_GT(interior, 1000);
  EXPECT_LT(steep, interior / 10);
}

INSTANTIATE_TEST_SUITE_P(ReferenceMaps, SharedMap,
                         ::testing::Values("scene20.2.pcd", "spiral0.3_2.pcd"));

}  // namespace
}  // namespace strata

namespace strata {
namespace {

TEST(TerrainModel, AssessmentIsReproducibleWhateverTheThreads) {
  const PointCloud cloud = GenerateStairsRampRoom(/*seed=*/9, /*spacing_m=*/0.05);
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  std::optional<TerrainFields::Parts> reference;
  for (const int threads : {1, 2, 2, 1}) {
    config.num_threads = threads;
    auto model = TerrainModel::Assess(cloud, config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    const TerrainFields::Parts fields = (*model)->fields().ToParts();
    if (!reference.has_value()) {
      reference = fields;
      continue;
    }
    EXPECT_EQ(fields.distance, reference->distance) << "threads " << threads;
    EXPECT_EQ(fields.safety, reference->safety) << "threads " << threads;
  }
}

}  // namespace
}  // namespace strata

namespace strata {
namespace {

// A 10° ramp rising along +x as a voxel map does it: one point per 0.2 m voxel, heights on
// a 0.2 m lattice (a staircase), plus a one-voxel groove across a flat landing beyond it.
PointCloud VoxelRampWithGroove() {
  constexpr double kQ = 0.2;
  const double slope = std::tan(10.0 * std::numbers::pi / 180);
  PointCloud cloud;
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 40; ++j) {
      const double x = (i + 0.5) * kQ;
      const double y = (j + 0.5) * kQ;
      double z = std::round(std::min(x, 12.0) * slope / kQ) * kQ;
      if (i == 80) z -= kQ;  // The groove, on the landing (x > 12 m).
      cloud.emplace_back(x, y, z);
    }
  }
  return cloud;
}

TEST(TerrainModel, VoxelStaircaseFitsAsTheSlopeItSamplesAndAGrooveAsFlat) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  auto model = TerrainModel::Assess(VoxelRampWithGroove(), config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_NEAR((*model)->summary().vertical_quantum_m, 0.2, 1e-6);
  const double slope = std::tan(10.0 * std::numbers::pi / 180);
  for (double x = 2.1; x < 10; x += 0.4) {  // Ramp interior, away from its ends and sides.
    const auto levels = test_util::LevelsAt(**model, {x, 4.1, 0});
    ASSERT_EQ(levels.size(), 1u) << "x " << x;
    // A staircase of 1.13 m treads seen through a 1 m disc reads between flat and steep;
    // it must never read as steep as the 20° limit, and its plane must follow the slope.
    EXPECT_NEAR(levels[0].tilt_rad * 180 / std::numbers::pi, 10.0, 6.0) << "x " << x;
    EXPECT_NEAR(levels[0].plane_center_z_m, x * slope, 0.1) << "x " << x;
  }
  const auto groove = test_util::LevelsAt(**model, {16.1, 4.1, 0});  // Column i = 80.
  ASSERT_EQ(groove.size(), 1u);
  EXPECT_LT(groove[0].tilt_rad, 0.05) << "a one-voxel groove is not a 90° edge";
}

TEST(TerrainModel, FieldConfigForQuantumWidensTheFitOnlyForVoxelMaps) {
  const FieldConfig field;
  const FieldConfig same = FieldConfigForQuantum(field, 0, 0.2);
  EXPECT_EQ(same.plane_fit_radius_m, field.plane_fit_radius_m);
  EXPECT_FALSE(same.plane_fit_column_tops);
  EXPECT_FALSE(FieldConfigForQuantum(field, 0.05, 0.2).plane_fit_column_tops);
  const FieldConfig voxel = FieldConfigForQuantum(field, 0.2, 0.2);
  EXPECT_NEAR(voxel.plane_fit_radius_m, 1.0, 1e-12);
  EXPECT_NEAR(voxel.plane_fit_half_height_m, 0.3, 1e-12);
  EXPECT_NEAR(voxel.plane_inlier_distance_m, 0.15, 1e-12);
  EXPECT_TRUE(voxel.plane_fit_column_tops);
}

TEST(TerrainModel, VerticalQuantumIgnoresAFewStrayPointsButNotScatteredHeights) {
  PointCloud lattice;  // Heights 0.05 + 0.15 k, as scene20.2's.
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 50; ++j)
      lattice.emplace_back(0.15f * i, 0.15f * j, 0.05f + 0.15f * (i % 12));
  }
  EXPECT_NEAR(DetectVerticalQuantum(lattice), 0.15, 1e-4);
  PointCloud strays = lattice;  // scene20.2's two points at z = 0.
  strays.emplace_back(1.0f, 1.0f, 0.0f);
  strays.emplace_back(1.15f, 1.0f, 0.0f);
  EXPECT_NEAR(DetectVerticalQuantum(strays), 0.15, 1e-4);
  PointCloud scattered = lattice;  // 2% of the points at arbitrary heights: not a lattice.
  for (int k = 0; k < 200; ++k) scattered.emplace_back(0.3f * k, 0.0f, 0.0137f * k + 0.003f);
  EXPECT_EQ(DetectVerticalQuantum(scattered), 0.0);
  PointCloud sensor;
  for (int k = 0; k < 10000; ++k) sensor.emplace_back(0.01f * k, 0.0f, 0.5f * std::sin(0.01 * k));
  EXPECT_EQ(DetectVerticalQuantum(sensor), 0.0);
}

// The Valid Ground Filter scans the points above each point in the columns around it: on a
// dense patch (a sensor that dwelt on one spot) or one point repeated, that was the square of
// the points (100,000 on 1 m² took 23 s). Each column keeps one point per cube of a cell edge
// / 8, so a 1 m² patch at 0.2 m holds at most a few thousand, whatever was sent.
TEST(TerrainModel, ADenseOrRepeatedCloudIsThinnedBeforeTheGroundFilter) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  PointCloud dense;
  for (int i = 0; i < 20000; ++i) {
    const float x = unit(rng);
    dense.emplace_back(x, unit(rng), 0.2f * x);  // A gentle slope: every point is ground.
  }
  const PointCloud repeated(100000, Eigen::Vector3f(1.0f, 1.0f, 1.0f));
  AssessmentConfig config;  // 0.2 m cells: cubes of 2.5 cm.
  auto slope = TerrainModel::Assess(dense, config);
  ASSERT_TRUE(slope.ok()) << slope.error().message;
  EXPECT_EQ((*slope)->summary().input_points, 20000u);
  // 40 × 40 cubes of 2.5 cm over the patch, the slope crossing at most two layers of each.
  EXPECT_LE((*slope)->summary().valid_ground_points, 2u * 40 * 40);
  EXPECT_GE((*slope)->summary().valid_ground_points, 40u * 40 / 2);
  auto one = TerrainModel::Assess(repeated, config);
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_EQ((*one)->summary().valid_ground_points, 1u);
}

// Thinning keeps every point of a cloud with at most one per cube (a voxel map, like the
// shared maps): the valid ground is what the filter finds on the whole cloud.
TEST(TerrainModel, ThinningLeavesALatticeCloudWhole) {
  const PointCloud cloud = VoxelRampWithGroove();
  AssessmentConfig config;
  auto model = TerrainModel::Assess(cloud, config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  ASSERT_GT((*model)->summary().vertical_quantum_m, 0.0);
  const std::vector<std::uint8_t> valid = FilterValidGround(
      cloud, config.ground, 0, internal::StepTolerance((*model)->summary().vertical_quantum_m));
  std::size_t count = 0;
  for (const std::uint8_t v : valid) count += v;
  EXPECT_EQ((*model)->summary().valid_ground_points, count);
}

}  // namespace
}  // namespace strata
