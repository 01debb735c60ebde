#include "strata/trajectory_verifier.hpp"

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/robot_profile.hpp"
#include "strata/surface_graph.hpp"
#include "strata/terrain_model.hpp"
#include "test_util/hand_made_maps.hpp"
#include "test_util/trajectory_builders.hpp"

namespace strata {
namespace {

using test_util::MinimumJerk;
using ::testing::HasSubstr;

constexpr double kRampSlopeRad = 10.0 * std::numbers::pi / 180.0;

PointCloud Yard() {
  test_util::CloudBuilder b(0.05);
  const auto in_hole = [](double x, double y) { return x > 1 && x < 2 && y > 4.5 && y < 5.5; };
  const auto under_ramp = [](double x, double y) { return x > 6.99 && y > 0.99 && y < 5.01; };
  b.Surface(
      0, 12, 0, 6, [](double, double) { return 0.0; },
      [&](double x, double y) { return !in_hole(x, y) && !under_ramp(x, y); });
  b.Plate(2, 4, 2, 4, 0.45);
  b.Surface(7, 10, 1, 5, [](double x, double) { return (x - 7) * std::tan(kRampSlopeRad); });
  b.Plate(10.05, 12, 1, 5, 3 * std::tan(kRampSlopeRad));
  return b.cloud();
}

const TerrainModel& Model() {
  static const std::shared_ptr<const TerrainModel> model = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    return TerrainModel::Assess(Yard(), config).value();
  }();
  return *model;
}

// The graph the verifier checks against, for `profile` as Plan builds it.
SurfaceGraph GraphFor(const RobotProfile& profile) {
  return SurfaceGraph::Build(Model(), profile.Traversability()).value();
}

RobotProfile Biped() { return BuiltinProfile("biped").value(); }

// The biped under the slab (clearance 0.45 m, read from the map), body held at `body_m`.
Trajectory UnderTheSlab(double body_m) {
  const double z = Biped().reference_height_m;
  return MinimumJerk(Eigen::Vector4d(2.5, 3.0, z, body_m), Eigen::Vector4d(3.5, 3.0, z, body_m), 4);
}

TEST(VerifyTrajectory, KeepsTheProfilesHeadroomAboveTheCommandedBody) {
  const RobotProfile biped = Biped();
  const SurfaceGraph graph = GraphFor(biped);
  const VerifierConfig config;
  const int node = graph.NodeNear(graph.grid().CellOf({3.0, 3.0, 0.2}).x(),
                                  graph.grid().CellOf({3.0, 3.0, 0.2}).y(), 0.0);
  ASSERT_GE(node, 0);
  const double clearance = graph.ceiling_clearance(node);
  ASSERT_NEAR(clearance, 0.45, 1e-6);
  // The body may eat into the headroom by the verifier's stated tolerance, no more.
  const double highest =
      clearance - biped.headroom_m + config.limit_tolerance * biped.body_height_max_m;
  VerificationReport report;
  const Status refused =
      VerifyTrajectory(graph, biped, UnderTheSlab(highest + 0.002), config, &report);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kOptimizationFailed);
  EXPECT_THAT(refused.error().message, HasSubstr("headroom"));
  const Status passed =
      VerifyTrajectory(graph, biped, UnderTheSlab(highest - 0.002), config, &report);
  EXPECT_TRUE(passed.ok()) << passed.error().message;
  EXPECT_NEAR(report.min_headroom_m, clearance - (highest - 0.002), 1e-6);
}

}  // namespace
}  // namespace strata
