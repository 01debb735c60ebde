#include "strata/assessment/map_edit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "assessment/map_edit_internal.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/io/tiled_edit.hpp"
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

MapEdit Scan(PointCloud points, double x0, double y0, double x1, double y1, double z0, double z1) {
  return {MapEdit::Kind::kScan,
          BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1))),
          std::make_shared<const PointCloud>(std::move(points))};
}

// What a sensor sees of a flat floor at height z over [x0, x1] × [y0, y1]: a point every
// `spacing_m`, each off the plane by up to 5 mm (seeded).
PointCloud FloorScan(double x0, double y0, double x1, double y1, double z, double spacing_m,
                     std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> noise(-0.005, 0.005);
  PointCloud points;
  for (double y = y0; y <= y1 + 1e-9; y += spacing_m) {
    for (double x = x0; x <= x1 + 1e-9; x += spacing_m) {
      points.emplace_back(static_cast<float>(x), static_cast<float>(y),
                          static_cast<float>(z + noise(random)));
    }
  }
  return points;
}

// What a sensor sees of a box standing on the floor (a pallet stack): its top and four sides,
// a point every `spacing_m` (denser than the thinning's cubes), each off by up to 5 mm.
PointCloud BoxScan(const Eigen::AlignedBox3d& box, double spacing_m, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> noise(-0.005, 0.005);
  PointCloud points;
  const auto add = [&](double x, double y, double z) {
    points.emplace_back(static_cast<float>(x + noise(random)),
                        static_cast<float>(y + noise(random)),
                        static_cast<float>(z + noise(random)));
  };
  const Eigen::Vector3d lo = box.min(), hi = box.max();
  for (double y = lo.y(); y <= hi.y() + 1e-9; y += spacing_m) {
    for (double x = lo.x(); x <= hi.x() + 1e-9; x += spacing_m) add(x, y, hi.z());
  }
  for (double z = lo.z(); z < hi.z() - 1e-9; z += spacing_m) {
    for (double x = lo.x(); x <= hi.x() + 1e-9; x += spacing_m) {
      add(x, lo.y(), z);
      add(x, hi.y(), z);
    }
    for (double y = lo.y() + spacing_m; y < hi.y() - 1e-9; y += spacing_m) {
      add(lo.x(), y, z);
      add(hi.x(), y, z);
    }
  }
  return points;
}

// A scan of a pallet stack (1.2 × 1.0 × 1.2 m) centred at (x, y) on the floor at `floor_z`,
// with the floor around it, of the region `half_m` around (x, y) from 0.3 m under the floor
// to 1.5 m above it; the sensor also saw the floor 1 m beyond the region.
MapEdit PalletScan(double x, double y, double floor_z, double half_m, std::uint32_t seed) {
  const Eigen::AlignedBox3d pallet(Eigen::Vector3d(x - 0.6, y - 0.5, floor_z),
                                   Eigen::Vector3d(x + 0.6, y + 0.5, floor_z + 1.2));
  PointCloud points;
  for (const Eigen::Vector3f& p : FloorScan(x - half_m - 1, y - half_m - 1, x + half_m + 1,
                                            y + half_m + 1, floor_z, 0.05, seed)) {
    if (!pallet.contains(Eigen::Vector3d(p.x(), p.y(), pallet.center().z()))) points.push_back(p);
  }
  const PointCloud box = BoxScan(pallet, 0.02, seed + 1);
  points.insert(points.end(), box.begin(), box.end());
  return Scan(std::move(points), x - half_m, y - half_m, x + half_m, y + half_m, floor_z - 0.3,
              floor_z + 1.5);
}

struct Scene {
  PointCloud cloud;
  std::shared_ptr<const TerrainModel> model;
};

// Outside the tiles of the columns `reassessed` says changed, the fresh assessment of the edited
// cloud cuts into the base's tiles, model and cloud alike: what a map store may keep of the
// base's instead of cutting them anew.
void ExpectUnchangedOutside(const Scene& base, const PointCloud& edited_cloud,
                            const TerrainModel& fresh, const Reassessment& reassessed) {
  const GridGeometry& grid = base.model->grid();
  const std::vector<std::size_t> changed = TilesTouching(grid, reassessed.changed_columns);
  ASSERT_FALSE(changed.empty());
  if (reassessed.path == ReassessmentPath::kFull) {
    EXPECT_EQ(changed.size(), TileCount(fresh.grid()));
    return;
  }
  const TiledModel base_tiles = CutModel(*base.model);
  const TiledModel fresh_tiles = CutModel(fresh);
  const std::vector<std::string> base_cloud = CutCloud(base.cloud, grid);
  const std::vector<std::string> edited = CutCloud(edited_cloud, grid);
  ASSERT_EQ(fresh_tiles.tiles.size(), base_tiles.tiles.size());
  for (std::size_t t = 0; t < base_tiles.tiles.size(); ++t) {
    if (std::binary_search(changed.begin(), changed.end(), t)) continue;
    EXPECT_TRUE(fresh_tiles.tiles[t] == base_tiles.tiles[t]) << "model tile " << t;
    EXPECT_TRUE(edited[t] == base_cloud[t]) << "cloud tile " << t;
  }
  // The changed tiles alone cut as the whole cut does.
  const TiledModel cut = CutModelTiles(fresh, changed);
  const std::vector<std::string> cloud_cut = CutCloudTiles(edited_cloud, grid, changed);
  EXPECT_EQ(cut.header, fresh_tiles.header);
  ASSERT_EQ(cut.tiles.size(), changed.size());
  ASSERT_EQ(cloud_cut.size(), changed.size());
  for (std::size_t k = 0; k < changed.size(); ++k) {
    EXPECT_TRUE(cut.tiles[k] == fresh_tiles.tiles[changed[k]]) << "model tile " << changed[k];
    EXPECT_TRUE(cloud_cut[k] == edited[changed[k]]) << "cloud tile " << changed[k];
  }
}

// EditTiledTerrain of `edits` on `base` cut into tiles, checked against a fresh assessment of
// the cloud its tiles then hold, byte for byte: the header and every tile, the changed ones cut
// from the window it read and the others the base's. `fresh_bytes`, when given, are those of a
// fresh assessment of the same edits applied to the whole cloud (BytesWithoutTimings), which
// the tiles must then equal (it saves assessing again). True when it edited the tiles, false
// when it said it needs the whole cloud (`*needs_whole`: why).
bool ExpectTiledEditLikeFresh(const Scene& base, const std::vector<MapEdit>& edits,
                              std::string* needs_whole, const std::string* fresh_bytes = nullptr) {
  const GridGeometry& grid = base.model->grid();
  const TiledModel model = CutModel(*base.model);
  std::vector<std::string> cloud = CutCloud(base.cloud, grid);
  std::vector<std::size_t> read;  // Cloud and model tiles read, each counted once.
  const auto from = [&read](const std::vector<std::string>& tiles) {
    return [&read, &tiles](std::size_t t) -> Expected<std::string> {
      read.push_back(t);
      return tiles.at(t);
    };
  };
  const TiledTerrainSource source{model.header, from(model.tiles), from(cloud)};
  Expected<TiledTerrainEdit> edit = EditTiledTerrain(source, edits);
  EXPECT_TRUE(edit.ok()) << edit.error().message;
  if (!edit.ok()) return false;
  *needs_whole = edit->needs_whole;
  if (!edit->needs_whole.empty()) return false;
  // A window, not the whole terrain (the scenes have 30 tiles and more).
  EXPECT_LT(read.size(), model.tiles.size());
  std::vector<std::string> tiles = model.tiles;
  EXPECT_EQ(edit->model.tiles.size(), edit->changed.size());
  EXPECT_EQ(edit->cloud.size(), edit->changed.size());
  if (edit->model.tiles.size() != edit->changed.size() ||
      edit->cloud.size() != edit->changed.size()) {
    return false;
  }
  for (std::size_t k = 0; k < edit->changed.size(); ++k) {
    tiles[edit->changed[k]] = edit->model.tiles[k];
    cloud[edit->changed[k]] = edit->cloud[k];
  }
  const std::vector<std::string_view> cloud_views(cloud.begin(), cloud.end());
  Expected<PointCloud> edited_cloud = JoinCloud(cloud_views, "edited");
  EXPECT_TRUE(edited_cloud.ok());
  if (!edited_cloud.ok()) return false;
  EXPECT_EQ(edit->cloud_points, edited_cloud->size());
  const std::vector<std::string_view> views(tiles.begin(), tiles.end());
  Expected<std::shared_ptr<const TerrainModel>> joined =
      JoinModel(edit->model.header, views, "edited");
  EXPECT_TRUE(joined.ok()) << joined.error().message;
  if (!joined.ok()) return false;
  std::string assessed_bytes;
  if (fresh_bytes == nullptr) {
    auto assessed = TerrainModel::Assess(*edited_cloud, base.model->config(), {},
                                         base.model->summary().vertical_quantum_m);
    EXPECT_TRUE(assessed.ok());
    if (!assessed.ok()) return false;
    assessed_bytes = test_util::BytesWithoutTimings(**assessed);
    fresh_bytes = &assessed_bytes;
  }
  const std::string tiled_bytes = test_util::BytesWithoutTimings(**joined);
  EXPECT_TRUE(tiled_bytes == *fresh_bytes)
      << "the tiled edit's model differs from a fresh assessment from byte "
      << test_util::FirstDifferingByte(tiled_bytes, *fresh_bytes) << " of " << fresh_bytes->size();
  EXPECT_NE(tiled_bytes, test_util::BytesWithoutTimings(*base.model));
  return true;
}

// Applies `edits`, reassesses locally and checks the model against a fresh assessment of the
// edited cloud, byte for byte. Returns the reassessment for further checks.
// `next`, when given, receives the edited cloud and its reassessed model: the scene the next
// edit applies to.
Reassessment ExpectReassessedLikeFresh(const Scene& scene, const std::vector<MapEdit>& edits,
                                       ReassessmentPath expected_path, Scene* next = nullptr) {
  Expected<PointCloud> edited = ApplyEdits(scene.cloud, edits, *scene.model);
  EXPECT_TRUE(edited.ok()) << edited.error().message;
  if (!edited.ok()) return {};
  Expected<Reassessment> reassessed =
      ReassessRegion(*scene.model, scene.cloud, *edited, EditBounds(edits));
  EXPECT_TRUE(reassessed.ok()) << reassessed.error().message;
  if (!reassessed.ok()) return {};
  EXPECT_EQ(reassessed->path, expected_path) << reassessed->full_reason;
  // The map keeps its quantum (TerrainModel::Assess).
  auto fresh = TerrainModel::Assess(*edited, scene.model->config(), {},
                                    scene.model->summary().vertical_quantum_m);
  EXPECT_TRUE(fresh.ok()) << fresh.error().message;
  if (!fresh.ok()) return {};
  const std::string local_bytes = test_util::BytesWithoutTimings(*reassessed->model);
  const std::string fresh_bytes = test_util::BytesWithoutTimings(**fresh);
  EXPECT_TRUE(local_bytes == fresh_bytes)
      << "the reassessed model differs from a fresh assessment from byte "
      << test_util::FirstDifferingByte(local_bytes, fresh_bytes) << " of " << fresh_bytes.size();
  // An edit that changed nothing would prove nothing.
  EXPECT_NE(local_bytes, test_util::BytesWithoutTimings(*scene.model));
  ExpectUnchangedOutside(scene, *edited, **fresh, *reassessed);
  // The same edit read from tiles: local where the whole edit is, unless a bounding-box face
  // it drops leaves the bounds to the whole cloud.
  std::string needs_whole;
  const bool tiled = ExpectTiledEditLikeFresh(scene, edits, &needs_whole, &fresh_bytes);
  if (expected_path == ReassessmentPath::kFull) EXPECT_FALSE(tiled);
  if (!tiled) std::printf("tiled edit needs the whole cloud: %s\n", needs_whole.c_str());
  if (next != nullptr) *next = Scene{std::move(edited).value(), reassessed->model};
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

// A sensor's heights are off the lattice of a voxelised map: a scan's points are moved to the
// nearest level, so the map keeps its quantum and the edit stays local.
TEST_F(VoxelisedTerrain, AScanOffTheLatticeIsMovedOntoIt) {
  const Eigen::Vector2d c = OpenSpot(1.5, 1.0);
  const double ground = layout().HeightAt(c.x(), c.y());
  const Prism region = BoxPrism({Eigen::Vector3d(c.x() - 1.5, c.y() - 1.5, ground - 1),
                                 Eigen::Vector3d(c.x() + 1.5, c.y() + 1.5, ground + 1.6)});
  PointCloud on_lattice;
  for (const Eigen::Vector3f& p : scene().cloud) {
    if (region.Contains(p.cast<double>())) on_lattice.push_back(p);
  }
  ASSERT_GT(on_lattice.size(), 50u);
  // And a block 0.6 × 0.6 × 0.8 m on the ground, at the voxel centres of the map's lattice.
  const auto voxel_centre = [](double v) { return (std::floor(v / 0.2) + 0.5) * 0.2; };
  for (double x = voxel_centre(c.x() - 0.3); x <= c.x() + 0.3; x += 0.2) {
    for (double y = voxel_centre(c.y() - 0.3); y <= c.y() + 0.3; y += 0.2) {
      for (double z = voxel_centre(ground); z <= voxel_centre(ground + 0.8) + 1e-6; z += 0.2) {
        on_lattice.emplace_back(static_cast<float>(x), static_cast<float>(y),
                                static_cast<float>(z));
      }
    }
  }
  // What a sensor reports: every height up to 7 cm off its level.
  PointCloud off_lattice = on_lattice;
  for (std::size_t i = 0; i < off_lattice.size(); ++i) {
    off_lattice[i].z() += i % 2 ? 0.07f : -0.06f;
  }
  const auto scan = [&](PointCloud points) {
    return Scan(std::move(points), c.x() - 1.5, c.y() - 1.5, c.x() + 1.5, c.y() + 1.5, ground - 1,
                ground + 1.6);
  };
  const MapEdit seen = scan(off_lattice);
  const Expected<PointCloud> from_sensor = ApplyEdits(scene().cloud, {&seen, 1}, *scene().model);
  const MapEdit exact = scan(on_lattice);
  const Expected<PointCloud> from_lattice = ApplyEdits(scene().cloud, {&exact, 1}, *scene().model);
  ASSERT_TRUE(from_sensor.ok() && from_lattice.ok());
  EXPECT_EQ(*from_sensor, *from_lattice);
  ExpectReassessedLikeFresh(scene(), {seen}, ReassessmentPath::kLocal);
}

// A scan of a voxelised map on its own lattice (the ground seen again, and a block standing on
// it): the quantum holds and only the columns around it are assessed again.
TEST_F(VoxelisedTerrain, AScanOnTheLatticeReassessesLikeAFreshAssessment) {
  const Eigen::Vector2d c = OpenSpot(1.5, 1.0);
  const double ground = layout().HeightAt(c.x(), c.y());
  const Prism region = BoxPrism({Eigen::Vector3d(c.x() - 1.5, c.y() - 1.5, ground - 1),
                                 Eigen::Vector3d(c.x() + 1.5, c.y() + 1.5, ground + 1.6)});
  PointCloud points;
  for (const Eigen::Vector3f& p : scene().cloud) {
    if (region.Contains(p.cast<double>())) points.push_back(p);
  }
  ASSERT_GT(points.size(), 50u);
  // A solid block 1 × 1 m from the ground up to 1 m above it: the centres of its voxels
  // (0.2 m, the map's own).
  const auto voxel_centre = [](double v) { return (std::floor(v / 0.2) + 0.5) * 0.2; };
  const double top = voxel_centre(ground + 1.0);
  for (double x = voxel_centre(c.x() - 0.5); x <= c.x() + 0.5; x += 0.2) {
    for (double y = voxel_centre(c.y() - 0.5); y <= c.y() + 0.5; y += 0.2) {
      for (double z = voxel_centre(ground); z <= top + 1e-6; z += 0.2) {
        points.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
      }
    }
  }
  const MapEdit scan = Scan(std::move(points), c.x() - 1.5, c.y() - 1.5, c.x() + 1.5, c.y() + 1.5,
                            ground - 1, ground + 1.6);
  const Reassessment r = ExpectReassessedLikeFresh(scene(), {scan}, ReassessmentPath::kLocal);
  ASSERT_NE(r.model, nullptr);
  EXPECT_EQ(r.model->summary().vertical_quantum_m, scene().model->summary().vertical_quantum_m);
  // The block's top is ground in its columns (at 0.1 m on a 0.2 m lattice, some are empty).
  double highest = -1e9, highest_before = -1e9;
  for (double dx = -0.3; dx <= 0.3; dx += 0.1) {
    for (double dy = -0.3; dy <= 0.3; dy += 0.1) {
      if (const ColumnSurface* s = TopSurface(*r.model, c.x() + dx, c.y() + dy)) {
        highest = std::max(highest, double{s->ground_z_m});
      }
      if (const ColumnSurface* s = TopSurface(*scene().model, c.x() + dx, c.y() + dy)) {
        highest_before = std::max(highest_before, double{s->ground_z_m});
      }
    }
  }
  EXPECT_LT(highest_before, ground + 0.3);
  EXPECT_NEAR(highest, top, 1e-3);
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

// A tiled edit whose reassessed columns end at a tile's edge: the new fields there read the
// surfaces of the next tile, which the window must hold although the edit changes none of it.
TEST_F(Garage, ATiledEditReadsTheSurfacesPastTheTilesItChanges) {
  const GridGeometry& g = scene().model->grid();
  const Eigen::AlignedBox3d probe(Eigen::Vector3d(5, 5, 0), Eigen::Vector3d(5, 5, 0));
  const internal::EditReach at_probe = internal::ReachOfEdit(
      scene().model->config(), g, scene().model->summary().vertical_quantum_m, probe);
  const int fields_reach = at_probe.fields_changed.max.x() - at_probe.touched.max.x();
  // The edit's last column, so that its reassessed columns end at the first tile's last one.
  const int last = kTileColumns - 1 - fields_reach;
  ASSERT_GT(last, 10);
  const double x1 = g.origin_m.x() + (last + 0.5) * g.resolution_m;
  const double floor_z = layout().level_z_m[0];
  const std::vector<MapEdit> edits = {Removal(x1 - 1.5, 8, x1, 10, floor_z - 0.3, floor_z + 0.3)};
  const internal::EditReach reach = internal::ReachOfEdit(
      scene().model->config(), g, scene().model->summary().vertical_quantum_m, EditBounds(edits));
  ASSERT_EQ(reach.fields_changed.max.x(), kTileColumns - 1);
  ASSERT_GE(reach.surfaces_read.max.x(), kTileColumns);
  std::string needs_whole;
  EXPECT_TRUE(ExpectTiledEditLikeFresh(scene(), edits, &needs_whole)) << needs_whole;
}

// A tiled edit that drops the cloud's highest points cannot tell the new bounds from the tiles
// it reads (another tile may hold a point as high): it says so, and the whole cloud decides.
TEST_F(Garage, ATiledEditDroppingTheHighestPointsNeedsTheWholeCloud) {
  const Eigen::Vector3f top = *std::max_element(
      scene().cloud.begin(), scene().cloud.end(),
      [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return a.z() < b.z(); });
  const std::vector<MapEdit> edits = {Removal(top.x() - 0.5, top.y() - 0.5, top.x() + 0.5,
                                              top.y() + 0.5, top.z() - 0.1, top.z() + 0.1)};
  std::string needs_whole;
  EXPECT_FALSE(ExpectTiledEditLikeFresh(scene(), edits, &needs_whole));
  EXPECT_THAT(needs_whole, HasSubstr("bounding box"));
  // The same points dropped from just under the top: the bounds hold, the tiles do.
  const std::vector<MapEdit> under = {Removal(top.x() - 0.5, top.y() - 0.5, top.x() + 0.5,
                                              top.y() + 0.5, top.z() - 0.6, top.z() - 0.2)};
  EXPECT_TRUE(ExpectTiledEditLikeFresh(scene(), under, &needs_whole)) << needs_whole;
}

// Scans one after another, each edit applied to the cloud and model the one before made (as
// the map store makes versions), mixed with obstacles and removals: every model is the one a
// fresh assessment of its cloud makes. A pallet stack scanned on a deck blocks the floor
// there; a scan of bare floor clears an obstacle away.
TEST_F(Garage, ScansOneAfterAnotherReassessLikeAFreshAssessment) {
  const double deck1 = layout().level_z_m[1];
  const double deck2 = layout().level_z_m[2];
  const double deck3 = layout().level_z_m[3];
  const Eigen::Vector2d a = FreeFloor(2, 1.6);
  const Eigen::Vector2d b = FreeFloor(1, 1.6);
  const Eigen::Vector2d c = FreeFloor(3, 1.6);
  const auto top_z = [](const Scene& scene, const Eigen::Vector2d& p, double below_z) {
    // The highest surface of p's column below `below_z` (under the deck above).
    const Eigen::Vector3i cell = scene.model->grid().CellOf({p.x(), p.y(), 0});
    double z = -1e9;
    for (const ColumnSurface& s : scene.model->surfaces().Column(cell.x(), cell.y())) {
      if (s.ground_z_m < below_z) z = std::max(z, double{s.ground_z_m});
    }
    return z;
  };
  Scene step = scene();

  // 1. A pallet stack scanned on deck 2: its column's floor is now the stack's top.
  ASSERT_NEAR(top_z(step, a, deck3 - 1), deck2, 0.1);
  ExpectReassessedLikeFresh(step, {PalletScan(a.x(), a.y(), deck2, 1.6, 1)},
                            ReassessmentPath::kLocal, &step);
  EXPECT_NEAR(top_z(step, a, deck3 - 1), deck2 + 1.2, 0.1);

  // 2. An obstacle on deck 1 with a notch removed from it, in one update.
  ExpectReassessedLikeFresh(
      step,
      {Obstacle(b.x() - 1, b.y() - 1, b.x() + 1, b.y() + 1, deck1, deck1 + 1),
       Removal(b.x() - 0.2, b.y() - 1.5, b.x() + 0.2, b.y() + 1.5, deck1 + 0.5, deck1 + 2)},
      ReassessmentPath::kLocal, &step);
  const Eigen::Vector2d beside_notch = b + Eigen::Vector2d(0.6, 0);
  EXPECT_GT(top_z(step, beside_notch, deck2 - 1), deck1 + 0.7);

  // 3. A scan of the bare floor there: the obstacle is gone, the floor is ground again.
  ExpectReassessedLikeFresh(
      step,
      {Scan(FloorScan(b.x() - 2, b.y() - 2, b.x() + 2, b.y() + 2, deck1, 0.05, 3), b.x() - 1.6,
            b.y() - 1.6, b.x() + 1.6, b.y() + 1.6, deck1 - 0.1, deck1 + 1.5)},
      ReassessmentPath::kLocal, &step);
  EXPECT_NEAR(top_z(step, beside_notch, deck2 - 1), deck1, 0.05);
  const Eigen::Vector3i cell = step.model->grid().CellOf({beside_notch.x(), beside_notch.y(), 0});
  EXPECT_TRUE(std::any_of(
      step.model->surfaces().Column(cell.x(), cell.y()).begin(),
      step.model->surfaces().Column(cell.x(), cell.y()).end(),
      [&](const ColumnSurface& s) { return s.valid && std::abs(s.ground_z_m - deck1) < 0.05; }));

  // 4. In one update: a pallet stack on the roof with a corner taken off it, and the stack on
  // deck 2 scanned away.
  ExpectReassessedLikeFresh(
      step,
      {PalletScan(c.x(), c.y(), deck3, 1.6, 4),
       Removal(c.x() + 0.2, c.y() + 0.1, c.x() + 1, c.y() + 1, deck3 + 0.6, deck3 + 2),
       Scan(FloorScan(a.x() - 1.6, a.y() - 1.6, a.x() + 1.6, a.y() + 1.6, deck2, 0.05, 6),
            a.x() - 1.6, a.y() - 1.6, a.x() + 1.6, a.y() + 1.6, deck2 - 0.1, deck2 + 1.5)},
      ReassessmentPath::kLocal, &step);
  EXPECT_NEAR(top_z(step, c, 1e9), deck3 + 1.2, 0.1);
  EXPECT_NEAR(top_z(step, a, deck3 - 1), deck2, 0.05);
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

// A scan drops what its region held and adds its own points inside the region, thinned to
// the lowest (then earliest) of each cube of a cell edge / 8 as the assessment thins a column,
// in the scan's order; those outside the region are counted, not added.
TEST_F(Garage, AScanAddsItsThinnedPointsInsideItsRegionOnly) {
  const double deck = layout().level_z_m[2];
  const Eigen::Vector2d c = FreeFloor(2, 1.6);
  const MapEdit scan = PalletScan(c.x(), c.y(), deck, 1.6, 5);
  const PointCloud& points = *scan.points;
  ScanCounts counts;
  Expected<PointCloud> a =
      ApplyEdits(scene().cloud, std::vector<MapEdit>{scan}, *scene().model, &counts);
  Expected<PointCloud> b = ApplyEdits(scene().cloud, std::vector<MapEdit>{scan}, *scene().model);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(*a == *b);
  const auto inside = [&](const Eigen::Vector3f& p) {
    return scan.region.Contains(p.cast<double>());
  };
  PointCloud kept;
  for (const Eigen::Vector3f& p : scene().cloud) {
    if (!inside(p)) kept.push_back(p);
  }
  ASSERT_LT(kept.size(), scene().cloud.size());
  ASSERT_GE(a->size(), kept.size());
  EXPECT_TRUE(std::equal(kept.begin(), kept.end(), a->begin()));
  const std::span<const Eigen::Vector3f> added(a->data() + kept.size(), a->size() - kept.size());

  // The counts add up, and the sensor's view past the region and the pallet's 2 cm sampling
  // both left points out.
  const auto outside = static_cast<std::size_t>(
      std::count_if(points.begin(), points.end(), [&](const auto& p) { return !inside(p); }));
  EXPECT_GT(outside, 0u);
  EXPECT_EQ(counts.outside_region, outside);
  EXPECT_EQ(counts.added, added.size());
  EXPECT_GT(counts.thinned, 0u);
  EXPECT_EQ(counts.added + counts.thinned + counts.outside_region, points.size());

  // Against the definition: the cubes of edge resolution / 8 from the grid's origin, each
  // holding its lowest (then earliest) point of the scan inside the region.
  const GridGeometry& g = scene().model->grid();
  const double leaf = g.resolution_m / 8;
  using Cube = std::tuple<std::int64_t, std::int64_t, std::int64_t>;
  const auto cube_of = [&](const Eigen::Vector3f& p) {
    const auto index = [&](float v, int axis) {
      return static_cast<std::int64_t>(std::floor((v - g.origin_m[axis]) / leaf));
    };
    return Cube{index(p.x(), 0), index(p.y(), 1), index(p.z(), 2)};
  };
  std::map<Cube, std::pair<float, std::size_t>> lowest;  // Cube → (z, index in the scan).
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!inside(points[i])) continue;
    const auto [it, fresh] = lowest.try_emplace(cube_of(points[i]), points[i].z(), i);
    if (!fresh && points[i].z() < it->second.first) it->second = {points[i].z(), i};
  }
  ASSERT_EQ(added.size(), lowest.size());
  std::vector<std::size_t> expected;
  for (const auto& [cube, first] : lowest) expected.push_back(first.second);
  std::sort(expected.begin(), expected.end());  // In the scan's order.
  for (std::size_t k = 0; k < added.size(); ++k) {
    EXPECT_EQ(added[k], points[expected[k]]) << k;
  }

  // A scan that saw nothing empties its region, as a removal does.
  MapEdit nothing = scan;
  nothing.points = nullptr;
  Expected<PointCloud> emptied =
      ApplyEdits(scene().cloud, std::vector<MapEdit>{nothing}, *scene().model);
  ASSERT_TRUE(emptied.ok());
  EXPECT_TRUE(*emptied == kept);
}

TEST_F(Garage, ApplyEditsRefusesBadScansNamingTheField) {
  const TerrainModel& model = *scene().model;
  const GridGeometry& g = model.grid();
  const Eigen::Vector3d grid_max = g.origin_m + g.size.cast<double>() * g.resolution_m;
  const PointCloud floor = FloorScan(2, 2, 3, 3, 0, 0.1, 7);

  // Past the grid's west edge, and above its top: a scan never extends the map.
  auto e = ApplyEdits(
      scene().cloud,
      std::vector<MapEdit>{Obstacle(3, 3, 5, 5, 0, 1), Scan(floor, -5, 2, 3, 3, -0.1, 1)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(e.error().field, "edits[1].region");
  EXPECT_THAT(e.error().message, HasSubstr("spans (-5.00, 2.00, -0.10) – (3.00, 3.00, 1.00) m"));
  EXPECT_THAT(e.error().message,
              HasSubstr(fmt::format("beyond the map's grid ({:.2f}, {:.2f}, {:.2f}) – ({:.2f}, "
                                    "{:.2f}, {:.2f}) m",
                                    g.origin_m.x(), g.origin_m.y(), g.origin_m.z(), grid_max.x(),
                                    grid_max.y(), grid_max.z())));
  e = ApplyEdits(scene().cloud,
                 std::vector<MapEdit>{Scan(floor, 2, 2, 3, 3, -0.1, grid_max.z() + 0.1)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[0].region");
  // Just inside: accepted.
  EXPECT_TRUE(ApplyEdits(scene().cloud,
                         std::vector<MapEdit>{Scan(floor, 2, 2, 3, 3, -0.1, grid_max.z())}, model)
                  .ok());

  // A point that is not finite, named by its index.
  PointCloud bad = floor;
  bad[3].y() = std::numeric_limits<float>::quiet_NaN();
  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{Scan(bad, 2, 2, 3, 3, -0.1, 1)}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(e.error().field, "edits[0].points[3]");
  EXPECT_THAT(e.error().message, HasSubstr("not finite"));

  // Points on an edit that is not a scan.
  MapEdit obstacle = Obstacle(2, 2, 3, 3, 0, 1);
  obstacle.points = std::make_shared<const PointCloud>(floor);
  e = ApplyEdits(scene().cloud, std::vector<MapEdit>{obstacle}, model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "edits[0].points");

  // More points than an edit may add, in one scan or with the edits before it (counted as the
  // scan holds them, outside its region too, before any is sorted).
  const Eigen::Vector3f far(30, 20, 0);  // Outside the region: cheap to count.
  e = ApplyEdits(scene().cloud,
                 std::vector<MapEdit>{Scan(PointCloud(kMaxEditPoints + 1, far), 2, 2, 3, 3, 0, 1)},
                 model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(e.error().field, "edits[0].points");
  EXPECT_THAT(e.error().message, HasSubstr("kMaxEditPoints = 4000000"));
  const MapEdit block = Obstacle(3, 3, 5, 5, 0, 1);
  Expected<PointCloud> with_block = ApplyEdits(scene().cloud, std::vector<MapEdit>{block}, model);
  ASSERT_TRUE(with_block.ok());
  const std::size_t block_points = with_block->size() - scene().cloud.size();
  e = ApplyEdits(
      scene().cloud,
      std::vector<MapEdit>{
          block, Scan(PointCloud(kMaxEditPoints - block_points + 1, far), 2, 2, 3, 3, 0, 1)},
      model);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(e.error().field, "edits[1]");
  EXPECT_THAT(e.error().message, HasSubstr("kMaxEditPoints = 4000000"));
  ScanCounts counts;
  ASSERT_TRUE(
      ApplyEdits(scene().cloud,
                 std::vector<MapEdit>{
                     block, Scan(PointCloud(kMaxEditPoints - block_points, far), 2, 2, 3, 3, 0, 1)},
                 model, &counts)
          .ok());
  EXPECT_EQ(counts.outside_region, kMaxEditPoints - block_points);
  EXPECT_EQ(counts.added, 0u);
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
