#include "strata/assessment/map_edit.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/io/saved_model.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "test_util/model_bytes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

// A voxelised copy of `cloud`: every point moved to the centre of its `voxel_m` voxel, one
// point per voxel, as the shared maps are made.
PointCloud Voxelise(const PointCloud& cloud, double voxel_m) {
  std::vector<std::tuple<int, int, int>> keys;
  for (const Eigen::Vector3f& p : cloud) {
    keys.emplace_back(static_cast<int>(std::floor(p.x() / voxel_m)),
                      static_cast<int>(std::floor(p.y() / voxel_m)),
                      static_cast<int>(std::floor(p.z() / voxel_m)));
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  PointCloud out;
  for (const auto& [x, y, z] : keys) {
    out.emplace_back(static_cast<float>((x + 0.5) * voxel_m),
                     static_cast<float>((y + 0.5) * voxel_m),
                     static_cast<float>((z + 0.5) * voxel_m));
  }
  return out;
}

MapEdit Obstacle(double x0, double y0, double x1, double y1, double z0, double z1) {
  return {MapEdit::Kind::kAddObstacle,
          BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)))};
}

MapEdit Removal(double x0, double y0, double x1, double y1, double z0, double z1) {
  return {MapEdit::Kind::kRemovePoints,
          BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)))};
}

struct Scene {
  PointCloud cloud;
  std::shared_ptr<const TerrainModel> model;
};

// Applies `edits`, reassesses locally and checks the model against a fresh assessment of the
// edited cloud, byte for byte. Returns the reassessment for further checks.
Reassessment ExpectReassessedLikeFresh(const Scene& scene, const std::vector<MapEdit>& edits,
                                       ReassessmentPath expected_path) {
  Expected<PointCloud> edited = ApplyEdits(scene.cloud, edits, *scene.model);
  EXPECT_TRUE(edited.ok()) << edited.error().message;
  if (!edited.ok()) return {};
  Expected<Reassessment> reassessed =
      ReassessRegion(*scene.model, scene.cloud, *edited, EditBounds(edits));
  EXPECT_TRUE(reassessed.ok()) << reassessed.error().message;
  if (!reassessed.ok()) return {};
  EXPECT_EQ(reassessed->path, expected_path) << reassessed->full_reason;
  auto fresh = TerrainModel::Assess(*edited, scene.model->config());
  EXPECT_TRUE(fresh.ok()) << fresh.error().message;
  if (!fresh.ok()) return {};
  const std::string local_bytes = test_util::BytesWithoutTimings(*reassessed->model);
  const std::string fresh_bytes = test_util::BytesWithoutTimings(**fresh);
  EXPECT_TRUE(local_bytes == fresh_bytes)
      << "the reassessed model differs from a fresh assessment from byte "
      << test_util::FirstDifferingByte(local_bytes, fresh_bytes) << " of " << fresh_bytes.size();
  // An edit that changed nothing would prove nothing.
  EXPECT_NE(local_bytes, test_util::BytesWithoutTimings(*scene.model));
  return std::move(reassessed).value();
}

// The highest surface of the column holding (x, y) [m].
const ColumnSurface* TopSurface(const TerrainModel& model, double x, double y) {
  const Eigen::Vector3i cell = model.grid().CellOf({x, y, 0});
  const auto column = model.surfaces().Column(cell.x(), cell.y());
  return column.empty() ? nullptr : &column.back();
}

// ---------------------------------------------------------------------------------------------
// A voxelised cloud (0.2 m lattice, assessed at 0.1 m like the spiral): rolling terrain.

class VoxelisedTerrain : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new Scene;
    scene_->cloud = Voxelise(GenerateUnevenTerrain(3, 0.1), 0.2);
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    auto model = TerrainModel::Assess(scene_->cloud, config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    scene_->model = *model;
    layout_ = new UnevenTerrainLayout(GetUnevenTerrainLayout(3));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete layout_;
  }
  static const Scene& scene() { return *scene_; }
  static const UnevenTerrainLayout& layout() { return *layout_; }

  // A spot (x, y) whose `half_m` square keeps `clearance_m` from every tree and rock.
  static Eigen::Vector2d OpenSpot(double half_m, double clearance_m) {
    for (double y = 5; y < 25; y += 0.5) {
      for (double x = 5; x < 25; x += 0.5) {
        bool clear = true;
        for (const auto& t : layout().trees) {
          clear &= std::hypot(t.x_m - x, t.y_m - y) > half_m * 1.5 + t.crown_radius_m + clearance_m;
        }
        for (const auto& r : layout().rocks) {
          clear &= std::hypot(r.x_m - x, r.y_m - y) > half_m * 1.5 + r.radius_xy_m + clearance_m;
        }
        if (clear && layout().GradientAt(x, y).norm() < 0.2) return {x, y};
      }
    }
    ADD_FAILURE() << "no open spot";
    return {15, 15};
  }

 private:
  static Scene* scene_;
  static UnevenTerrainLayout* layout_;
};

Scene* VoxelisedTerrain::scene_ = nullptr;
UnevenTerrainLayout* VoxelisedTerrain::layout_ = nullptr;

TEST_F(VoxelisedTerrain, TheSceneIsVoxelised) {
  EXPECT_NEAR(scene().model->summary().vertical_quantum_m, 0.2, 1e-3);
}

TEST_F(VoxelisedTerrain, AnObstacleInTheOpenReassessesLikeAFreshAssessment) {
  const Eigen::Vector2d c = OpenSpot(1.0, 2.0);
  const double ground = layout().HeightAt(c.x(), c.y());
  const std::vector<MapEdit> edits = {
      Obstacle(c.x() - 1, c.y() - 1, c.x() + 1, c.y() + 1, ground - 0.6, ground + 1.0)};
  const Reassessment r = ExpectReassessedLikeFresh(scene(), edits, ReassessmentPath::kLocal);
  ASSERT_NE(r.model, nullptr);
  // The block stands where it was put: the column's top is the block's top lattice level,
  // and the edited cloud keeps the map's lattice.
  const ColumnSurface* top = TopSurface(*r.model, c.x(), c.y());
  ASSERT_NE(top, nullptr);
  EXPECT_GT(top->ground_z_m, ground + 0.75);
  EXPECT_LE(top->ground_z_m, ground + 1.0 + 1e-4);
  EXPECT_EQ(r.model->summary().vertical_quantum_m, scene().model->summary().vertical_quantum_m);
  EXPECT_LT(r.reassessed_columns, r.model->grid().LayerCellCount() / 4);
}

TEST_F(VoxelisedTerrain, AHoleReassessesLikeAFreshAssessment) {
  const Eigen::Vector2d c = OpenSpot(1.5, 1.0);
  const double ground = layout().HeightAt(c.x(), c.y());
  const std::vector<MapEdit> edits = {
      Removal(c.x() - 1.5, c.y() - 1.5, c.x() + 1.5, c.y() + 1.5, ground - 5, ground + 5)};
  const Reassessment r = ExpectReassessedLikeFresh(scene(), edits, ReassessmentPath::kLocal);
  ASSERT_NE(r.model, nullptr);
  EXPECT_TRUE(r.model->surfaces()
                  .Column(r.model->grid().CellOf({c.x(), c.y(), 0}).x(),
                          r.model->grid().CellOf({c.x(), c.y(), 0}).y())
                  .empty());
}

TEST_F(VoxelisedTerrain, AnObstacleAgainstATreeTrunkReassessesLikeAFreshAssessment) {
  const auto& tree = layout().trees.front();
  const double x = tree.x_m + tree.trunk_radius_m;  // The block's west face touches the trunk.
  ExpectReassessedLikeFresh(scene(),
                            {Obstacle(x, tree.y_m - 0.5, x + 1.0, tree.y_m + 0.5,
                                      tree.ground_z_m - 0.4, tree.ground_z_m + 0.8)},
                            ReassessmentPath::kLocal);
}

TEST_F(VoxelisedTerrain, AnEditAtTheMapsBorderReassessesLikeAFreshAssessment) {
  // Inside the cloud's bounds, against its west edge: the windows are cut by the grid.
  const double ground = layout().HeightAt(1.0, 15.0);
  ExpectReassessedLikeFresh(scene(), {Obstacle(0.15, 14, 1.5, 16, ground - 1.0, ground + 0.6)},
                            ReassessmentPath::kLocal);
  ExpectReassessedLikeFresh(scene(), {Removal(-1, 20, 2, 23, -10, 20)}, ReassessmentPath::kLocal);
}

TEST_F(VoxelisedTerrain, AnObstacleBeyondTheMapIsAssessedAfreshAndSaysWhy) {
  const double ground = layout().HeightAt(29.5, 15.0);
  const Reassessment r = ExpectReassessedLikeFresh(
      scene(), {Obstacle(29, 14, 34, 16, ground - 1.0, ground + 0.6)}, ReassessmentPath::kFull);
  EXPECT_THAT(r.full_reason, HasSubstr("change the grid"));
}

TEST_F(VoxelisedTerrain, ObstaclesKeepTheLatticeAndStayInsideTheirPrism) {
  const Eigen::Vector2d c = OpenSpot(1.0, 2.0);
  const MapEdit edit = Obstacle(c.x() - 1, c.y() - 1, c.x() + 1, c.y() + 1, 0, 3);
  Expected<PointCloud> edited =
      ApplyEdits(scene().cloud, std::vector<MapEdit>{edit}, *scene().model);
  ASSERT_TRUE(edited.ok()) << edited.error().message;
  ASSERT_GT(edited->size(), scene().cloud.size());
  EXPECT_TRUE(std::equal(scene().cloud.begin(), scene().cloud.end(), edited->begin()));
  // The block's heights are the map's lattice levels: 0.1, 0.3, ... (voxel centres).
  for (std::size_t i = scene().cloud.size(); i < edited->size(); ++i) {
    const Eigen::Vector3f& p = (*edited)[i];
    EXPECT_TRUE(edit.region.Contains(p.cast<double>()));
    const double k = (p.z() - 0.1) / 0.2;
    EXPECT_NEAR(k, std::round(k), 1e-4) << p.z();
  }
  EXPECT_EQ(DetectVerticalQuantum(*edited), DetectVerticalQuantum(scene().cloud));
}

// ---------------------------------------------------------------------------------------------
// A sensor's cloud on several levels: the parking garage.

class Garage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new Scene;
    scene_->cloud = GenerateParkingGarage(1, 0.2);
    AssessmentConfig config;
    config.grid.resolution_m = 0.2;
    auto model = TerrainModel::Assess(scene_->cloud, config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    scene_->model = *model;
    layout_ = new GarageLayout(GetGarageLayout());
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete layout_;
  }
  static const Scene& scene() { return *scene_; }
  static const GarageLayout& layout() { return *layout_; }

  // A spot on `level` whose `half_m` square has floor and keeps 1 m from cars and pillars.
  static Eigen::Vector2d FreeFloor(int level, double half_m) {
    const GarageLayout& g = layout();
    for (double y = 2; y < g.y_max_m - 2; y += 0.5) {
      for (double x = 2; x < g.x_max_m - 2; x += 0.5) {
        bool ok = true;
        for (double dx : {-half_m - 1, 0.0, half_m + 1}) {
          for (double dy : {-half_m - 1, 0.0, half_m + 1}) ok &= g.HasFloor(level, x + dx, y + dy);
        }
        for (const auto& ramp : g.ramps) {
          ok &= x + half_m + 1 < ramp.x_min_m || x - half_m - 1 > ramp.x_max_m ||
                y + half_m + 1 < ramp.y_min_m || y - half_m - 1 > ramp.y_max_m;
        }
        for (const auto& [lo, hi] : g.cars_m) {
          ok &= x + half_m + 1 < lo.x() || x - half_m - 1 > hi.x() || y + half_m + 1 < lo.y() ||
                y - half_m - 1 > hi.y();
        }
        for (const Eigen::Vector2d& p : g.pillar_centers_m) {
          ok &= std::abs(p.x() - x) > half_m + 1 + g.pillar_size_m ||
                std::abs(p.y() - y) > half_m + 1 + g.pillar_size_m;
        }
        if (ok) return {x, y};
      }
    }
    ADD_FAILURE() << "no free floor on level " << level;
    return {10, 10};
  }

 private:
  static Scene* scene_;
  static GarageLayout* layout_;
};

Scene* Garage::scene_ = nullptr;
GarageLayout* Garage::layout_ = nullptr;

TEST_F(Garage, TheSceneIsASensorsCloud) {
  EXPECT_EQ(scene().model->summary().vertical_quantum_m, 0);
}

TEST_F(Garage, AnObstacleOnAnUpperDeckReassessesLikeAFreshAssessment) {
  const double deck = layout().level_z_m[2];
  const Eigen::Vector2d c = FreeFloor(2, 1.0);
  const Reassessment r = ExpectReassessedLikeFresh(
      scene(), {Obstacle(c.x() - 1, c.y() - 1, c.x() + 1, c.y() + 1, deck, deck + 1.2)},
      ReassessmentPath::kLocal);
  ASSERT_NE(r.model, nullptr);
  // The block's top replaces the deck's surface in its columns (the slab and the block make
  // one run): as many levels as before, one of them at the block's top.
  const Eigen::Vector3i cell = r.model->grid().CellOf({c.x(), c.y(), 0});
  const auto column = r.model->surfaces().Column(cell.x(), cell.y());
  EXPECT_EQ(column.size(), scene().model->surfaces().Column(cell.x(), cell.y()).size());
  EXPECT_TRUE(std::any_of(column.begin(), column.end(), [&](const ColumnSurface& s) {
    return std::abs(s.ground_z_m - (deck + 1.2)) < 0.2;
  }));
}

TEST_F(Garage, AHoleInADeckReassessesLikeAFreshAssessment) {
  const double deck = layout().level_z_m[1];
  const Eigen::Vector2d c = FreeFloor(1, 1.5);
  ExpectReassessedLikeFresh(scene(),
                            {Removal(c.x() - 1.5, c.y() - 1.5, c.x() + 1.5, c.y() + 1.5,
                                     deck - layout().slab_thickness_m - 0.05, deck + 0.05)},
                            ReassessmentPath::kLocal);
}

TEST_F(Garage, AnObstacleAgainstAPillarReassessesLikeAFreshAssessment) {
  const Eigen::Vector2d p = layout().pillar_centers_m.front();
  const double half = layout().pillar_size_m / 2;
  ExpectReassessedLikeFresh(
      scene(), {Obstacle(p.x() + half, p.y() - 0.6, p.x() + half + 1.2, p.y() + 0.6, 0, 1.0)},
      ReassessmentPath::kLocal);
}

TEST_F(Garage, AnObstacleAgainstTheOuterWallReassessesLikeAFreshAssessment) {
  // The parapet along x = 0 on the ground floor, at the grid's border.
  const Eigen::Vector2d c = FreeFloor(0, 1.0);
  ExpectReassessedLikeFresh(scene(), {Obstacle(0.0, c.y() - 1, 1.0, c.y() + 1, 0, 0.8)},
                            ReassessmentPath::kLocal);
}

TEST_F(Garage, EditsApplyInOrder) {
  // An obstacle, then a removal cutting a notch out of it: the same as a fresh assessment.
  const double deck = layout().level_z_m[3];
  const Eigen::Vector2d c = FreeFloor(3, 1.5);
  ExpectReassessedLikeFresh(
      scene(),
      {Obstacle(c.x() - 1.5, c.y() - 1.5, c.x() + 1.5, c.y() + 1.5, deck, deck + 1),
       Removal(c.x() - 0.5, c.y() - 2, c.x() + 0.5, c.y() + 2, deck + 0.1, deck + 2)},
      ReassessmentPath::kLocal);
}

// ---------------------------------------------------------------------------------------------
// ApplyEdits on its own.

TEST_F(Garage, ApplyEditsIsDeterministicAndKeepsEveryOtherPointInOrder) {
  const double deck = layout().level_z_m[2];
  const Eigen::Vector2d c = FreeFloor(2, 1.0);
  const std::vector<MapEdit> edits = {
      Removal(c.x() - 1, c.y() - 1, c.x() + 1, c.y() + 1, deck - 1, deck + 1),
      Obstacle(c.x() - 1, c.y() - 1, c.x() + 1, c.y() + 1, deck, deck + 1)};
  Expected<PointCloud> a = ApplyEdits(scene().cloud, edits, *scene().model);
  Expected<PointCloud> b = ApplyEdits(scene().cloud, edits, *scene().model);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(*a == *b);
  PointCloud kept;
  for (const Eigen::Vector3f& p : scene().cloud) {
    if (!edits[0].region.Contains(p.cast<double>())) kept.push_back(p);
  }
  ASSERT_LT(kept.size(), scene().cloud.size());
  ASSERT_GT(a->size(), kept.size());
  EXPECT_TRUE(std::equal(kept.begin(), kept.end(), a->begin()));
  // The obstacle: one point per column centre inside the footprint and layer centre inside
  // the height range, on the grid's lattice.
  const GridGeometry& g = scene().model->grid();
  for (std::size_t i = kept.size(); i < a->size(); ++i) {
    const Eigen::Vector3d p = (*a)[i].cast<double>();
    EXPECT_TRUE(edits[1].region.Contains(p));
    EXPECT_LT((p - g.CellCenter(g.CellOf(p))).norm(), 1e-5);
  }
  // ... and every such cell centre has its point.
  std::size_t centres_inside = 0;
  const Eigen::Vector3i lo = g.CellOf(edits[1].region.Bounds().min()) - Eigen::Vector3i::Ones();
  const Eigen::Vector3i hi = g.CellOf(edits[1].region.Bounds().max()) + Eigen::Vector3i::Ones();
  for (int iz = lo.z(); iz <= hi.z(); ++iz) {
    for (int iy = lo.y(); iy <= hi.y(); ++iy) {
      for (int ix = lo.x(); ix <= hi.x(); ++ix) {
        centres_inside += edits[1].region.Contains(g.CellCenter({ix, iy, iz}));
      }
    }
  }
  EXPECT_EQ(a->size() - kept.size(), centres_inside);
}

TEST_F(Garage, ApplyEditsRefusesBadEditsNamingTheField) {
  const TerrainModel& model = *scene().model;
  MapEdit two_corners = Obstacle(1, 1, 2, 2, 0, 1);
  two_corners.region.polygon_m.resize(2);
  auto e = ApplyEdits(scene().cloud, std::vector<MapEdit>{Obstacle(1, 1, 2, 2, 0, 1), two_corners},
                      model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(e.error().field, "edits[1].region.polygon_m");

  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{Removal(1, 1, 2, 2, 1, 0)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[0].region.z_max_m");

  MapEdit unknown = Obstacle(1, 1, 2, 2, 0, 1);
  unknown.kind = static_cast<MapEdit::Kind>(7);
  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{unknown}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[0].kind");

  // Narrower than a cell: no column centre inside.
  const double x = model.grid().CellCenter({20, 20, 0}).x() + 0.01;
  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{Obstacle(x, 3, x + 0.05, 5, 0, 1)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(e.error().field, "edits[0].region.polygon_m");
  EXPECT_THAT(e.error().message, HasSubstr("at least one cell wide"));

  // Thinner than a layer: no level inside.
  const double z = model.grid().CellCenter({0, 0, 10}).z() + 0.01;
  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{Obstacle(3, 3, 5, 5, z, z + 0.05)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[0].region");
  EXPECT_THAT(e.error().message, HasSubstr("high"));
}

TEST_F(Garage, ApplyEditsRefusesObstaclesAboveThePointLimitBeforeAllocating) {
  // 1 km × 1 km × 10 m at 0.2 m: 1.25e9 points, refused from the count.
  auto e = ApplyEdits(
      scene().cloud,
      std::vector<MapEdit>{Obstacle(0, 0, 20, 20, 0, 1), Obstacle(-500, -500, 500, 500, 0, 10)},
      *scene().model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(e.error().field, "edits[1]");
  EXPECT_THAT(e.error().message, HasSubstr("kMaxEditPoints = 4000000"));
  // Within the limit alone, but not with what the earlier edits add.
  const double side = std::sqrt(static_cast<double>(kMaxEditPoints) / 5) * 0.2;  // 5 layers.
  e = ApplyEdits(scene().cloud,
                 std::vector<MapEdit>{Obstacle(0, 0, 20, 20, 0, 1),
                                      Obstacle(0, 0, side - 0.3, side - 0.3, 0, 1)},
                 *scene().model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[1]");
  ASSERT_TRUE(ApplyEdits(scene().cloud,
                         std::vector<MapEdit>{Obstacle(0, 0, side - 0.3, side - 0.3, 0, 1)},
                         *scene().model)
                  .ok());
}

TEST_F(Garage, ReassessRegionRefusesAnEmptyTouchedBoxAndStopsWhenAsked) {
  const std::vector<MapEdit> edits = {Obstacle(3, 3, 5, 5, 0, 1)};
  Expected<PointCloud> edited = ApplyEdits(scene().cloud, edits, *scene().model);
  ASSERT_TRUE(edited.ok());
  auto r = ReassessRegion(*scene().model, scene().cloud, *edited, Eigen::AlignedBox3d());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  AssessmentControl stop;
  stop.should_stop = [] { return true; };
  r = ReassessRegion(*scene().model, scene().cloud, *edited, EditBounds(edits), stop);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kCancelled);
}

}  // namespace
}  // namespace strata
