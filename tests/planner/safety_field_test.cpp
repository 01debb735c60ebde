#include "strata/assessment/safety_field.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "test_util/gradient_check.hpp"

#include "strata/assessment/plane_fit.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "test_util/hand_made_maps.hpp"
#include "test_util/terrain_queries.hpp"

namespace strata {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A square patch of the plane z = tan(slope)·(x cos(heading) + y sin(heading)), with jitter.
PointCloud InclinedPatch(double slope_rad, double heading_rad, double half_extent_m,
                         double spacing_m, double jitter_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-jitter_m, jitter_m);
  PointCloud cloud;
  for (double x = -half_extent_m; x <= half_extent_m; x += spacing_m) {
    for (double y = -half_extent_m; y <= half_extent_m; y += spacing_m) {
      const double px = x + jitter(rng);
      const double py = y + jitter(rng);
      const double along = px * std::cos(heading_rad) + py * std::sin(heading_rad);
      cloud.emplace_back(px, py, std::tan(slope_rad) * along + jitter(rng));
    }
  }
  return cloud;
}

TEST(ConeKernel, MatchesThePapersFormula) {
  for (const auto& [t, r] : {std::pair{0.4, 0.2}, {0.5, 0.2}, {0.3, 0.1}, {0.25, 0.3}}) {
    const Eigen::MatrixXd a = ConeKernel(t, r);
    const int m = 2 * static_cast<int>(std::ceil(t / r)) + 1;
    ASSERT_EQ(a.rows(), m);
    ASSERT_EQ(a.cols(), m);
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        const double c = (m - 1) / 2.0;
        const double expected =
            std::max(0.0, 1.0 - r * std::sqrt((i - c) * (i - c) + (j - c) * (j - c)) / t);
        EXPECT_DOUBLE_EQ(a(i, j), expected)
            << "t " << t << " r " << r << " (" << i << "," << j << ")";
      }
    }
    EXPECT_DOUBLE_EQ(a((m - 1) / 2, (m - 1) / 2), 1.0);
  }
  EXPECT_EQ(ConeKernel(0.0, 0.2).size(), 1);
}

TEST(DiffuseSafetyPenalty, SpreadsAnImpulseAsTheNormalisedCone) {
  GridGeometry g;
  g.resolution_m = 0.2;
  g.size = {15, 13, 3};
  std::vector<float> values(g.CellCount(), 0.0f);
  values[g.Index(7, 6, 1)] = 1.0f;
  FieldConfig field;
  field.diffusion_distance_m = 0.5;
  const ScalarGrid diffused = DiffuseSafetyPenalty(ScalarGrid(g, values), field);
  const Eigen::MatrixXd a = ConeKernel(0.5, 0.2);
  const int half = static_cast<int>(a.rows() / 2);
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      const int i = ix - 7 + half;
      const int j = iy - 6 + half;
      const double expected =
          (i >= 0 && j >= 0 && i < a.rows() && j < a.cols()) ? a(i, j) / a.sum() : 0.0;
      EXPECT_NEAR(diffused.at(ix, iy, 1), expected, 1e-6) << ix << "," << iy;
      EXPECT_EQ(diffused.at(ix, iy, 0), 0.0f);  // Layers do not mix.
    }
  }
}

// Cells inside an obstacle are no part of S': the kernel is renormalised over the others, and
// a cell whose whole kernel lies inside reads the void penalty.
TEST(DiffuseSafetyPenalty, LeavesCellsInsideObstaclesOut) {
  GridGeometry g;
  g.resolution_m = 0.2;
  g.size = {15, 13, 1};
  std::vector<float> values(g.CellCount(), 2.0f);
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 8; ix < g.size.x(); ++ix) values[g.Index(ix, iy, 0)] = kInsideObstacle;
  }
  values[g.Index(5, 6, 0)] = 4.0f;
  FieldConfig field;
  field.diffusion_distance_m = 0.5;  // Reach 3 cells.
  const ScalarGrid diffused = DiffuseSafetyPenalty(ScalarGrid(g, values), field);
  const Eigen::MatrixXd a = ConeKernel(0.5, 0.2);
  // Beside the obstacle (x = 7), the taps at x >= 8 are left out: the mean of what is left.
  double sum = 0, weight = 0;
  for (int i = 0; i < a.rows(); ++i) {
    for (int j = 0; j < a.cols(); ++j) {
      const int ix = 7 + i - 3, iy = 6 + j - 3;
      if (ix >= 8) continue;
      sum += a(i, j) * (ix == 5 && iy == 6 ? 4.0 : 2.0);
      weight += a(i, j);
    }
  }
  EXPECT_NEAR(diffused.at(7, 6, 0), sum / weight, 1e-6);
  EXPECT_NEAR(diffused.at(7, 0, 0), 2.0, 1e-6);  // Uniform ground stays uniform up to a wall.
  EXPECT_NEAR(diffused.at(14, 6, 0), field.VoidPenalty(), 1e-5);  // 4 cells deep.
}

TEST(FitLocalPlane, RecoversKnownSlopeWithinHalfADegree) {
  for (std::uint32_t seed = 1; seed <= 10; ++seed) {
    const double slope = (4.0 * seed) * kDeg;
    const double heading = 0.6 * seed;
    const PointCloud patch = InclinedPatch(slope, heading, 0.35, 0.05, 0.004, seed);
    const PlaneFit fit = FitLocalPlane(patch, 0.05, 64);
    ASSERT_GE(fit.inlier_count, 3);
    EXPECT_NEAR(fit.tilt_rad, slope, 0.5 * kDeg) << "slope " << slope / kDeg << " deg";
    EXPECT_GE(fit.normal.z(), 0.0);
  }
}

TEST(FitLocalPlane, RansacIgnoresAWallBesideTheFloor) {
  PointCloud patch = InclinedPatch(0.0, 0.0, 0.35, 0.05, 0.002, 4);
  // A wall face at x = 0.2 rising 0.35 m: a third of the points, none on the floor's plane.
  for (double y = -0.35; y <= 0.35; y += 0.05) {
    for (double z = 0.06; z <= 0.35; z += 0.05) patch.emplace_back(0.2, y, z);
  }
  const PlaneFit fit = FitLocalPlane(patch, 0.03, 64);
  EXPECT_LT(fit.tilt_rad, 1.0 * kDeg);
  EXPECT_NEAR(fit.center_m.z(), 0.0, 0.01);
}

TEST(FitLocalPlane, TooFewOrCollinearPointsGiveNoFit) {
  EXPECT_EQ(FitLocalPlane(PointCloud{{0, 0, 0}, {1, 0, 0}}, 0.05, 10).inlier_count, 0);
  EXPECT_EQ(
      FitLocalPlane(PointCloud{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}, 0.05, 10).inlier_count,
      0);
}

// Two floors, z = 0 for x < 0 and z = step for x >= 0, 4 × 4 m, sampled every 5 cm.
PointCloud StepCloud(double step_m) {
  PointCloud cloud;
  for (double x = -2.0; x < 2.0; x += 0.05) {
    for (double y = -2.0; y < 2.0; y += 0.05) cloud.emplace_back(x, y, x < 0 ? 0.0 : step_m);
  }
  return cloud;
}

std::shared_ptr<const TerrainModel> Assess(
    const PointCloud& cloud, double resolution_m,
    double max_tilt_rad = GroundFilterConfig{}.max_tilt_rad) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  config.ground.max_tilt_rad = max_tilt_rad;
  auto model = TerrainModel::Assess(cloud, config);
  EXPECT_TRUE(model.ok()) << model.error().message;
  return model.ok() ? *model : nullptr;
}

TEST(SafetyPenalty, StepEdgeGivesALargePoseChangeTerm) {
  const auto model = Assess(StepCloud(0.3), 0.1);
  ASSERT_TRUE(model);
  const GridGeometry& g = model->grid();
  const FieldConfig& field = model->config().field;
  const int iy = g.CellOf({0, 0, 0}).y();
  // Half a metre above the high floor: every column projects onto a floor.
  const int iz = g.CellOf({0, 0, 0.8}).z();
  const int edge_x = g.CellOf({0.01, 0, 0}).x();
  const double at_edge = PoseGradientNorm(model->surfaces(), field, edge_x, iy, iz);
  const double far_low =
      PoseGradientNorm(model->surfaces(), field, g.CellOf({-1, 0, 0}).x(), iy, iz);
  const double far_high =
      PoseGradientNorm(model->surfaces(), field, g.CellOf({1, 0, 0}).x(), iy, iz);
  // A 0.3 m jump over one or two cells: ‖∇H‖ ≥ 0.3 / (2 r).
  EXPECT_GE(at_edge, 0.3 / (2 * 0.1) - 1e-6);
  EXPECT_LT(far_low, 0.05);
  EXPECT_LT(far_high, 0.05);
  const double s_edge = model->SafetyPenalty(g.CellCenter({edge_x, iy, iz}));
  const double s_flat = model->SafetyPenalty(g.CellCenter({g.CellOf({-1, 0, 0}).x(), iy, iz}));
  EXPECT_GT(s_edge, 10 * s_flat + 0.1);
}

TEST(SafetyPenalty, TiltTermFollowsTheSlope) {
  for (const double slope_deg : {5.0, 15.0, 25.0}) {
    // A map assessed for slopes up to 30°, so that even the 25° patch is valid ground and
    // holds the fields.
    const auto model =
        Assess(InclinedPatch(slope_deg * kDeg, 0.3, 3.0, 0.05, 0.0, 1), 0.1, 30 * kDeg);
    ASSERT_TRUE(model);
    const ColumnSurface* s = test_util::SurfaceBelow(*model, {0.0, 0.0, 1.5});
    ASSERT_NE(s, nullptr);
    EXPECT_NEAR(s->tilt_rad, slope_deg * kDeg, 0.5 * kDeg);
    // Away from the patch's edge, S' on the slope is λ_f φ² plus a small pose-change term.
    const double penalty = model->SafetyPenalty({0.0, 0.0, 0.35});
    const double tilt_term = model->config().field.weight_tilt * std::pow(slope_deg * kDeg, 2);
    EXPECT_GE(penalty, 0.9 * tilt_term);
    EXPECT_LT(penalty, tilt_term + 0.8);
  }
}

TEST(SafetyPenalty, GradientMatchesFiniteDifferences) {
  const auto model = Assess(StepCloud(0.25), 0.1);
  ASSERT_TRUE(model);
  const GridGeometry& grid = model->grid();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-1.5, 1.5);
  std::uniform_real_distribution<double> z(0.1, 0.9);
  const double h = 1e-5;
  int checked = 0, varying = 0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    // S' is trilinear between cell centres, where its gradient jumps: differences across a
    // centre plane would measure the jump, not the gradient.
    const Eigen::Array3d u = (p - grid.origin_m).array() / grid.resolution_m - 0.5;
    if (((u - u.round()).abs() * grid.resolution_m < 2 * h).any()) continue;
    Eigen::Vector3d gradient;
    const double value = model->SafetyPenalty(p, &gradient);
    const Eigen::Vector3d numeric = test_util::NumericalFieldGradient(
        [&](const Eigen::Vector3d& q) { return model->SafetyPenalty(q); }, p, h);
    // Each component on its own, relative to its own size: linear along each axis inside a
    // cell, so only rounding separates the two.
    EXPECT_TRUE(test_util::GradientsMatchPerBlock(gradient, numeric,
                                                  {{"x", 0, 1}, {"y", 1, 1}, {"z", 2, 1}}, 1e-6,
                                                  test_util::FiniteDifferenceNoise(value, h)))
        << "at " << p.transpose();
    ++checked;
    varying += gradient.norm() > 1e-3;
  }
  EXPECT_GT(checked, 180);
  EXPECT_GT(varying, 20);  // The points must include places where S' actually varies.
}

// A floor with a wall 1.5 m high on one side and a drop of 1 m on the other, at indoor_tables'
// resolution. The ground filter has taken the footprint's radius off the floor beside the
// wall, and the distance and rim terms keep the robot from it; the wall's body adds nothing
// to S' there (1.46 at 0.1 m inside the rim, 2.95 at the rim, while a wall's inside counted as
// a void). Beside the drop S' is the edge's pose change, diffused, as before.
TEST(SafetyPenalty, AWallAddsNothingBesideItButADropStaysPenalised) {
  test_util::CloudBuilder site(0.05);
  site.Plate(-2.5, 3, -2, 2, 0)           // The floor,
      .Block(2.5, 2.7, -2, 2, 0.05, 1.5)  // a wall along its east side,
      .Plate(-4, -2.55, -2, 2, -1);       // a lower floor beyond its west edge.
  const auto model = Assess(site.cloud(), 0.2);
  ASSERT_TRUE(model);
  const double rim_beside_wall = 2.5 - model->config().ground.radius_m;
  EXPECT_LT(model->SafetyPenalty({0, 0, 0.3}), 0.1);
  EXPECT_LT(model->SafetyPenalty({rim_beside_wall - 0.1, 0, 0.3}), 0.5);  // 0.33 measured.
  EXPECT_LT(model->SafetyPenalty({rim_beside_wall, 0, 0.3}), 0.6);        // 0.44 measured.
  EXPECT_GT(model->SafetyPenalty({-2.5 + 0.1, 0, 0.3}), 0.6);             // 0.79 measured.
}

TEST(SafetyPenalty, VoidBelowGetsTheVoidPenalty) {
  const auto model = Assess(StepCloud(0.0), 0.2);
  ASSERT_TRUE(model);
  // Below the floor nothing supports the robot.
  const double below =
      model->SafetyPenalty(model->grid().CellCenter(model->grid().CellOf({0, 0, -0.6})));
  EXPECT_NEAR(below, model->config().field.VoidPenalty(), 1e-4);
}

}  // namespace
}  // namespace strata
