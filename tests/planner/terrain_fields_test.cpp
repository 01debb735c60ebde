#include "strata/assessment/terrain_fields.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/esdf.hpp"
#include "strata/assessment/safety_field.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const TerrainModel> AssessOrDie(const PointCloud& cloud, double resolution_m) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  auto model = TerrainModel::Assess(cloud, config);
  EXPECT_TRUE(model.ok()) << model.error().message;
  return model.ok() ? *model : nullptr;
}

// two_level_ramp (seed 1) at 0.25 m, assessed once for the tests that break a model's parts:
// null if the scene or its assessment failed.
std::shared_ptr<const TerrainModel> TwoLevelRamp() {
  static const std::shared_ptr<const TerrainModel> model = [] {
    const Expected<PointCloud> cloud = GenerateScene("two_level_ramp", 1);
    EXPECT_TRUE(cloud.ok());
    return cloud.ok() ? AssessOrDie(*cloud, 0.25) : nullptr;
  }();
  return model;
}

// The fields on every cell of the whole grid, computed densely as a reference.
struct DenseFields {
  ScalarGrid distance;
  ScalarGrid safety;
};

DenseFields DenseReference(const PointCloud& cloud, const TerrainModel& model) {
  const GridGeometry& g = model.grid();
  std::vector<std::uint8_t> occupied(static_cast<std::size_t>(g.CellCount()), 0);
  for (const Eigen::Vector3f& p : cloud) {
    const Eigen::Vector3i c =
        g.CellOf(p.cast<double>()).cwiseMax(0).cwiseMin(g.size - Eigen::Vector3i::Ones());
    occupied[g.Index(c)] = 1;
  }
  const FieldConfig& field = model.config().field;
  return {BuildSignedDistanceField(g, occupied),
          DiffuseSafetyPenalty(ComputeSafetyPenalty(model.surfaces(), field, CellBox::Whole(g)),
                               field)};
}

int LayerOf(const GridGeometry& g, double z) {
  return std::clamp(static_cast<int>(std::floor((z - g.origin_m.z()) / g.resolution_m)), 0,
                    g.size.z() - 1);
}

// Whether the band holds cell c: one layer below the ground of a valid surface of c's column
// or of a neighbouring one, up to one layer above that ground + the band height.
bool InBand(const TerrainModel& model, const Eigen::Vector3i& c) {
  const GridGeometry& g = model.grid();
  const double h = model.config().grid.band_height_m;
  for (int y = c.y() - 1; y <= c.y() + 1; ++y) {
    for (int x = c.x() - 1; x <= c.x() + 1; ++x) {
      if (x < 0 || y < 0 || x >= g.size.x() || y >= g.size.y()) continue;
      for (const ColumnSurface& s : model.surfaces().Column(x, y)) {
        if (s.valid && c.z() >= LayerOf(g, s.ground_z_m) - 1 &&
            c.z() <= LayerOf(g, s.ground_z_m + h) + 1) {
          return true;
        }
      }
    }
  }
  return false;
}

struct SceneCase {
  std::string scene;
  double resolution_m;
};

class BandAgainstDense : public ::testing::TestWithParam<SceneCase> {};

// Every stored value is the dense field's value at that cell, quantised (and d capped), and
// the band holds exactly the cells its definition names.
TEST_P(BandAgainstDense, StoresTheDenseValuesOnExactlyTheBand) {
  const Expected<PointCloud> cloud = GenerateScene(GetParam().scene, 3);
  ASSERT_TRUE(cloud.ok());
  const auto model = AssessOrDie(*cloud, GetParam().resolution_m);
  ASSERT_TRUE(model);
  const DenseFields dense = DenseReference(*cloud, *model);
  const GridGeometry& g = model->grid();
  const TerrainFields& fields = model->fields();
  const double cap = fields.distance_cap_m();
  const double safety_tolerance = 0.5 * fields.scalars().safety_step + 1e-5;
  std::size_t stored = 0, near_obstacles = 0, varied_safety = 0;
  for (int iz = 0; iz < g.size.z(); ++iz) {
    for (int iy = 0; iy < g.size.y(); ++iy) {
      for (int ix = 0; ix < g.size.x(); ++ix) {
        const Eigen::Vector3i c(ix, iy, iz);
        const std::optional<double> d = fields.DistanceAt(c);
        const std::optional<double> s = fields.SafetyAt(c);
        ASSERT_EQ(d.has_value(), s.has_value());
        ASSERT_EQ(d.has_value(), InBand(*model, c)) << "cell " << c.transpose();
        if (!d.has_value()) continue;
        ++stored;
        const double expected_d =
            std::clamp(double{dense.distance.at(ix, iy, iz)}, g.resolution_m - cap, cap);
        ASSERT_NEAR(*d, expected_d, 0.5 * TerrainFields::kDistanceStepM + 1e-6)
            << "d at cell " << c.transpose();
        ASSERT_NEAR(*s, dense.safety.at(ix, iy, iz), safety_tolerance)
            << "S' at cell " << c.transpose();
        near_obstacles += *d < 0.5 * cap;
        varied_safety += *s > 0.05;
      }
    }
  }
  // The comparison must have covered values that matter, not only background-like ones.
  EXPECT_GT(stored, 1000u);
  EXPECT_GT(near_obstacles, stored / 10);
  EXPECT_GT(varied_safety, 100u);
}

INSTANTIATE_TEST_SUITE_P(Scenes, BandAgainstDense,
                         ::testing::Values(SceneCase{"two_level_ramp", 0.2},
                                           SceneCase{"stairs_ramp_room", 0.1},
                                           SceneCase{"uneven_terrain", 0.2},
                                           SceneCase{"parking_garage", 0.25}),
                         [](const auto& info) { return info.param.scene; });

TEST(TerrainFields, SamplesAtAReferencePointNeverReadTheBackground) {
  // Anywhere a robot's reference point stands above valid ground, all eight corners of the
  // trilinear sample are stored: moving the point by a tiny step never jumps to background.
  const Expected<PointCloud> cloud = GenerateScene("two_level_ramp", 5);
  ASSERT_TRUE(cloud.ok());
  const auto model = AssessOrDie(*cloud, 0.2);
  ASSERT_TRUE(model);
  const GridGeometry& g = model->grid();
  const double r = g.resolution_m;
  int checked = 0;
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      for (const ColumnSurface& s : model->surfaces().Column(ix, iy)) {
        if (!s.valid) continue;
        for (const double height : {0.0, 0.3, 0.5 * model->config().grid.band_height_m,
                                    model->config().grid.band_height_m}) {
          const Eigen::Vector3d centre = g.CellCenter({ix, iy, 0});
          // Corners of the column's cell, where a sample reaches furthest.
          for (const double dx : {-0.49 * r, 0.49 * r}) {
            for (const double dy : {-0.49 * r, 0.49 * r}) {
              const Eigen::Vector3d p(centre.x() + dx, centre.y() + dy, s.ground_z_m + height);
              const Eigen::Vector3i base = ((p - g.origin_m) / r - Eigen::Vector3d::Constant(0.5))
                                               .array()
                                               .floor()
                                               .cast<int>();
              for (int k = 0; k < 8; ++k) {
                const Eigen::Vector3i corner = (base + Eigen::Vector3i(k & 1, (k >> 1) & 1, k >> 2))
                                                   .cwiseMax(0)
                                                   .cwiseMin(g.size - Eigen::Vector3i::Ones());
                ASSERT_TRUE(model->fields().DistanceAt(corner).has_value())
                    << "corner " << corner.transpose() << " of " << p.transpose();
              }
              ++checked;
            }
          }
        }
      }
    }
  }
  EXPECT_GT(checked, 10000);
}

TEST(TerrainFields, SampleMatchesTheSingleFieldQueriesAndFiniteDifferences) {
  const Expected<PointCloud> cloud = GenerateScene("uneven_terrain", 2);
  ASSERT_TRUE(cloud.ok());
  const auto model = AssessOrDie(*cloud, 0.2);
  ASSERT_TRUE(model);
  const TerrainFields& fields = model->fields();
  std::mt19937 rng(4);
  const GridGeometry& g = model->grid();
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double h = 1e-6;
  int varied = 0;
  for (int k = 0; k < 400; ++k) {
    const int ix = static_cast<int>(u(rng) * g.size.x()),
              iy = static_cast<int>(u(rng) * g.size.y());
    const auto column =
        model->surfaces().Column(std::min(ix, g.size.x() - 1), std::min(iy, g.size.y() - 1));
    if (column.empty() || !column.back().valid) continue;
    const Eigen::Vector3d centre = g.CellCenter({ix, iy, 0});
    const Eigen::Vector3d p(centre.x() + (u(rng) - 0.5) * g.resolution_m,
                            centre.y() + (u(rng) - 0.5) * g.resolution_m,
                            column.back().ground_z_m + 0.1 + 0.4 * u(rng));
    FieldSample sample;
    fields.Sample(p, &sample);
    Eigen::Vector3d grad_d, grad_s;
    EXPECT_EQ(sample.distance_m, fields.Distance(p, &grad_d));
    EXPECT_EQ(sample.safety, fields.SafetyPenalty(p, &grad_s));
    EXPECT_EQ(sample.distance_gradient, grad_d);
    EXPECT_EQ(sample.safety_gradient, grad_s);
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step[axis] = h;
      const double numeric_d = (fields.Distance(p + step) - fields.Distance(p - step)) / (2 * h);
      const double numeric_s =
          (fields.SafetyPenalty(p + step) - fields.SafetyPenalty(p - step)) / (2 * h);
      EXPECT_NEAR(grad_d[axis], numeric_d, 1e-5 * std::max(1.0, std::abs(numeric_d)));
      EXPECT_NEAR(grad_s[axis], numeric_s, 1e-5 * std::max(1.0, std::abs(numeric_s)));
    }
    varied += grad_d.norm() > 0.1 && grad_s.norm() > 1e-3;
  }
  EXPECT_GT(varied, 50);
}

// A block's key and bounds (what the optimiser's TerrainMemo relies on): every point of a
// block shares its key and lies within its corners' bounds, and a point a cell over has
// another key.
TEST(TerrainFields, ABlocksPointsShareItsKeyAndStayWithinItsBounds) {
  const std::shared_ptr<const TerrainModel> model = TwoLevelRamp();
  ASSERT_TRUE(model);
  const TerrainFields& fields = model->fields();
  const GridGeometry& g = model->grid();
  const double r = g.resolution_m;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int spread = 0;
  for (int k = 0; k < 300; ++k) {
    // A block spans the centres of cells i and i + 1 on each axis: from origin + (i + 0.5) r.
    // Not the last block of an axis, which also takes the points clamped beyond it.
    const Eigen::Vector3i cell(static_cast<int>(u(rng) * (g.size.x() - 2)),
                               static_cast<int>(u(rng) * (g.size.y() - 2)),
                               static_cast<int>(u(rng) * (g.size.z() - 2)));
    const Eigen::Vector3d low = g.CellCenter(cell);
    FieldSample first;
    FieldBlock block;
    fields.Sample(low + Eigen::Vector3d::Constant(0.5 * r), &first, &block);
    for (int j = 0; j < 8; ++j) {
      const Eigen::Vector3d p =
          low +
          r * Eigen::Vector3d(0.01 + 0.98 * u(rng), 0.01 + 0.98 * u(rng), 0.01 + 0.98 * u(rng));
      EXPECT_EQ(fields.BlockKey(p), block.key) << p.transpose();
      FieldSample sample;
      fields.Sample(p, &sample);
      EXPECT_LE(sample.safety, block.max_safety + 1e-12);
      EXPECT_GE(sample.distance_m, block.min_distance - 1e-12);
    }
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_NE(fields.BlockKey(low + Eigen::Vector3d::Constant(0.5 * r) +
                                r * Eigen::Vector3d::Unit(axis)),
                block.key);
    }
    spread += block.max_safety > block.min_distance;  // Not every block is one value.
  }
  EXPECT_GT(spread, 10);
}

TEST(TerrainFields, FromPartsRefusesInconsistentParts) {
  const auto model = TwoLevelRamp();
  ASSERT_TRUE(model);
  const TerrainFields::Parts good = model->fields().ToParts();
  ASSERT_TRUE(TerrainFields::FromParts(good).ok());
  const auto expect_refused = [](TerrainFields::Parts parts, const char* what) {
    const Expected<TerrainFields> fields = TerrainFields::FromParts(std::move(parts));
    ASSERT_FALSE(fields.ok()) << what;
    EXPECT_EQ(fields.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(fields.error().message, HasSubstr("inconsistent")) << what;
  };
  {
    TerrainFields::Parts p = good;
    p.distance.pop_back();
    expect_refused(p, "short values");
  }
  {
    TerrainFields::Parts p = good;
    p.column_begin.pop_back();
    expect_refused(p, "short column index");
  }
  {
    TerrainFields::Parts p = good;
    p.intervals[p.intervals.size() / 2].first_layer = p.geometry.size.z();
    expect_refused(p, "layer beyond the grid");
  }
  {
    TerrainFields::Parts p = good;
    std::swap(p.column_begin[p.column_begin.size() / 2],
              p.column_begin[p.column_begin.size() / 2 + 7]);
    if (p.column_begin != good.column_begin) expect_refused(p, "non-monotone index");
  }
  {
    TerrainFields::Parts p = good;
    p.safety_step = std::nan("");
    expect_refused(p, "NaN step");
  }
  {
    // Found by fuzz/saved_model_fuzzer: a column's end beyond the intervals, with the index's
    // last entry right; the check read past the intervals before it saw the order broken.
    TerrainFields::Parts p = good;
    p.column_begin[1] = p.column_begin.back() + 5;
    expect_refused(p, "a column past the intervals");
  }
}

TEST(SurfaceMap, FromPartsRefusesAColumnPastTheSurfaces) {
  // Found by fuzz/saved_model_fuzzer (heap-buffer-overflow before the fix): the index's first
  // and last entries are right, an inner one points past the surfaces.
  const auto model = TwoLevelRamp();
  ASSERT_TRUE(model);
  const SurfaceMap& surfaces = model->surfaces();
  auto [column_begin, all] = surfaces.ToParts();
  ASSERT_TRUE(SurfaceMap::FromParts(surfaces.geometry(), column_begin, all).ok());
  column_begin[1] = static_cast<std::uint32_t>(all.size() + 100);
  const Expected<SurfaceMap> broken = SurfaceMap::FromParts(surfaces.geometry(), column_begin, all);
  ASSERT_FALSE(broken.ok());
  EXPECT_THAT(broken.error().message, HasSubstr("not monotone"));
}

TEST(SurfaceMap, FromPartsRefusesGroundsThatDescendInAColumn) {
  // The terrain queries stop at the first ground above a point, which is right only when a
  // column's grounds ascend with its surfaces, as every assessed map's do.
  const auto model = TwoLevelRamp();
  ASSERT_TRUE(model);
  const SurfaceMap& surfaces = model->surfaces();
  auto [begin, all] = surfaces.ToParts();
  std::size_t upper = 0;  // The second surface of the first column with two.
  for (std::size_t c = 0; c + 1 < begin.size() && upper == 0; ++c) {
    if (begin[c + 1] - begin[c] >= 2) upper = begin[c] + 1;
  }
  ASSERT_GT(upper, 0u) << "two_level_ramp has a column with two levels";
  ASSERT_TRUE(SurfaceMap::FromParts(surfaces.geometry(), begin, all).ok());
  all[upper].ground_z_m = all[upper - 1].ground_z_m - 0.01f;
  const Expected<SurfaceMap> broken = SurfaceMap::FromParts(surfaces.geometry(), begin, all);
  ASSERT_FALSE(broken.ok());
  EXPECT_THAT(broken.error().message, HasSubstr("do not ascend"));
}

TEST(TerrainFields, MemoryGrowsWithTheGroundNotWithTheBoundingBox) {
  // The same scene on a grid padded by 1 m and by 20 m on every side: the padded grid has
  // over 30 times the cells, but the same ground, so the model grows only by the index of the
  // extra columns.
  const Expected<PointCloud> cloud = GenerateScene("two_level_ramp", 1);
  ASSERT_TRUE(cloud.ok());
  std::size_t bytes[2], columns[2];
  std::int64_t cells[2];
  for (const int i : {0, 1}) {
    AssessmentConfig config;
    config.grid.padding_m = i == 0 ? 1.0 : 20.0;
    const auto model = TerrainModel::Assess(*cloud, config);
    ASSERT_TRUE(model.ok());
    bytes[i] = (*model)->MemoryBytes();
    columns[i] = static_cast<std::size_t>((*model)->grid().LayerCellCount());
    cells[i] = (*model)->grid().CellCount();
  }
  EXPECT_GT(cells[1], 30 * cells[0]);
  // Index per column: one offset each for the surfaces and the fields; 2% slack for points
  // that fall on the other side of a column boundary when the origin moves by 19 m.
  EXPECT_LE(bytes[1] - bytes[0], 8 * (columns[1] - columns[0]) + bytes[0] / 50)
      << bytes[0] << " bytes, " << columns[0] << " columns; padded: " << bytes[1] << ", "
      << columns[1];
}

TEST(AssessTerrain, ATooLargeGridIsRefusedBeforeAnyHeavyWork) {
  // Two clusters of points 40 km apart: a grid of 4e10 columns at 0.2 m. Refused from the
  // bounds, before the points are even sorted (no stage starts).
  PointCloud cloud;
  for (int i = 0; i < 1000; ++i) {
    cloud.emplace_back(0.01f * static_cast<float>(i), 0.f, 0.f);
    cloud.emplace_back(40000.f + 0.01f * static_cast<float>(i), 40000.f, 0.f);
  }
  int reports = 0;
  AssessmentControl control;
  control.on_progress = [&](AssessmentStage, double) { ++reports; };
  const auto model = TerrainModel::Assess(cloud, AssessmentConfig{}, control);
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(model.error().message, HasSubstr("columns, above the limit of 1e+08"));
  EXPECT_EQ(reports, 0);
}

TEST(AssessTerrain, ReportsEveryStageInOrderAndCanBeCancelled) {
  const Expected<PointCloud> cloud = GenerateScene("two_level_ramp", 1);
  ASSERT_TRUE(cloud.ok());
  AssessmentConfig config;
  std::vector<std::pair<AssessmentStage, double>> reports;
  AssessmentControl control;
  control.on_progress = [&](AssessmentStage stage, double fraction) {
    reports.emplace_back(stage, fraction);
  };
  ASSERT_TRUE(TerrainModel::Assess(*cloud, config, control).ok());
  ASSERT_FALSE(reports.empty());
  for (std::size_t i = 1; i < reports.size(); ++i) {
    const auto& [stage, fraction] = reports[i];
    const auto& [previous_stage, previous_fraction] = reports[i - 1];
    ASSERT_GE(stage, previous_stage);
    if (stage == previous_stage) ASSERT_GE(fraction, previous_fraction);
    ASSERT_GE(fraction, 0.0);
    ASSERT_LE(fraction, 1.0);
  }
  for (const AssessmentStage stage : {AssessmentStage::kSorting, AssessmentStage::kGroundFilter,
                                      AssessmentStage::kSurfaces, AssessmentStage::kFields}) {
    EXPECT_TRUE(std::any_of(reports.begin(), reports.end(), [&](const auto& r) {
      return r.first == stage;
    })) << AssessmentStageName(stage);
  }

  // Stopping in each stage fails the assessment with kCancelled, naming the stage.
  for (const AssessmentStage stop_in :
       {AssessmentStage::kGroundFilter, AssessmentStage::kSurfaces, AssessmentStage::kFields}) {
    AssessmentStage current = AssessmentStage::kSorting;
    AssessmentControl stopping;
    stopping.on_progress = [&](AssessmentStage stage, double) { current = stage; };
    stopping.should_stop = [&] { return current == stop_in; };
    const auto cancelled = TerrainModel::Assess(*cloud, config, stopping);
    ASSERT_FALSE(cancelled.ok()) << AssessmentStageName(stop_in);
    EXPECT_EQ(cancelled.error().code, ErrorCode::kCancelled);
    EXPECT_THAT(cancelled.error().message, HasSubstr("cancelled"));
  }
}

}  // namespace
}  // namespace strata
