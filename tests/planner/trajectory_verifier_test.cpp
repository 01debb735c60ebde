// The verifier against hand-made trajectories on a hand-made map (test_util::Yard). For every kind
// of violation a trajectory that violates it by a small margin is refused, with a message that
// names the quantity, and the same trajectory just inside the bound passes.
#include "strata/verification/trajectory_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/prism.hpp"
#include "test_util/hand_made_maps.hpp"
#include "test_util/trajectory_builders.hpp"

namespace strata {
namespace {

using test_util::kMinimumJerkPeakAcceleration;
using test_util::kMinimumJerkPeakSpeed;
using test_util::MinimumJerk;
using ::testing::HasSubstr;

using test_util::kYardRampSlopeRad;
// How far past (or inside) a bound the trajectories go: relative for speeds and
// accelerations, in metres for heights and distances.
constexpr double kRelativeMargin = 0.003;
constexpr double kMarginM = 0.002;

const TerrainModel& Model() { return test_util::YardModel(); }

// The graph the verifier checks against, for `profile` as Plan builds it.
SurfaceGraph GraphFor(const RobotProfile& profile) {
  return SurfaceGraph::Build(Model(), profile.Traversability()).value();
}

RobotProfile Loose(const std::string& name) { return test_util::LooseProfile(name); }

Status Verify(const RobotProfile& profile, const Trajectory& trajectory,
              const VerifierConfig& config = {}, VerificationReport* report = nullptr) {
  VerificationReport scratch;
  return VerifyTrajectory(GraphFor(profile), profile, trajectory, config,
                          report != nullptr ? report : &scratch);
}

void ExpectRefused(const Status& status, const std::string& quantity) {
  ASSERT_FALSE(status.ok()) << "expected a refusal naming " << quantity;
  EXPECT_EQ(status.error().code, ErrorCode::kOptimizationFailed);
  EXPECT_THAT(status.error().message, HasSubstr("trajectory verification failed"));
  EXPECT_THAT(status.error().message, HasSubstr(quantity));
}

void ExpectPasses(const Status& status) { EXPECT_TRUE(status.ok()) << status.error().message; }

// A parameterised case's name: its quantity, spaces as underscores. gtest's default prints the
// case's bytes, a pointer among them, so the test names changed from build to build.
template <typename Case>
std::string NamedByQuantity(const ::testing::TestParamInfo<Case>& info) {
  std::string name = info.param.quantity;
  std::replace(name.begin(), name.end(), ' ', '_');
  return name;
}

// Rest to rest along the floor at y = 1 from x = 1 to 4 (3 m) in 4 s, the reference point
// rising by `rise_m` (centred on the reference height, plus `offset_m`); active-height
// profiles hold the body at `body_m`.
constexpr double kRunM = 3, kRunS = 4;
Trajectory AcrossTheFloor(const RobotProfile& profile, double rise_m = 0, double offset_m = 0,
                          double body_m = 0.65) {
  return test_util::FloorMotion(profile, {1, 1}, {1 + kRunM, 1}, kRunS,
                                {rise_m, offset_m, body_m, 2});
}

// Rest to rest over the floor at the reference height in 4 s.
Trajectory Along(const RobotProfile& profile, const Eigen::Vector2d& from,
                 const Eigen::Vector2d& to) {
  return test_util::FloorMotion(profile, from, to, 4);
}

TEST(VerifyTrajectory, ACleanTrajectoryPassesAndItsExtremesAreReported) {
  const RobotProfile profile = Loose("differential");
  VerificationReport report;
  ExpectPasses(Verify(profile, AcrossTheFloor(profile, 0.1), {}, &report));
  // Samples at most 2 cm apart along the path, and the analytic peaks found within 0.5%.
  EXPECT_GE(report.samples, kRunM / VerifierConfig{}.max_sample_spacing_m);
  EXPECT_NEAR(report.max_speed_horizontal_mps, kMinimumJerkPeakSpeed * kRunM / kRunS,
              0.005 * kMinimumJerkPeakSpeed * kRunM / kRunS);
  EXPECT_NEAR(report.max_accel_horizontal_mps2,
              kMinimumJerkPeakAcceleration * kRunM / (kRunS * kRunS),
              0.005 * kMinimumJerkPeakAcceleration * kRunM / (kRunS * kRunS));
  EXPECT_NEAR(report.max_ground_offset_m, 0.05, 1e-3);
  EXPECT_NEAR(report.max_tilt_rad, 0, 1e-3);
  EXPECT_EQ(report.min_headroom_m, std::numeric_limits<double>::infinity());
}

// Speed and acceleration, horizontal and vertical: the bound set so that the trajectory's
// analytic peak lies just above (refused) or just below (passes) bound × (1 + tolerance).
struct LimitCase {
  const char* quantity;
  double RobotProfile::*bound;
  double peak;
};

class VerifyLimits : public ::testing::TestWithParam<LimitCase> {};

TEST_P(VerifyLimits, RefusedJustOverTheBoundAndPassedJustUnder) {
  const LimitCase& c = GetParam();
  RobotProfile profile = Loose("differential");
  const Trajectory trajectory = AcrossTheFloor(profile, 0.1);
  const double allowed = 1 + VerifierConfig{}.limit_tolerance;
  profile.*c.bound = c.peak / allowed * (1 - kRelativeMargin);
  ExpectRefused(Verify(profile, trajectory), c.quantity);
  profile.*c.bound = c.peak / allowed * (1 + kRelativeMargin);
  ExpectPasses(Verify(profile, trajectory));
}

INSTANTIATE_TEST_SUITE_P(
    SpeedAndAcceleration, VerifyLimits,
    ::testing::Values(LimitCase{"horizontal speed", &RobotProfile::max_speed_horizontal_mps,
                                kMinimumJerkPeakSpeed* kRunM / kRunS},
                      LimitCase{"vertical speed", &RobotProfile::max_speed_vertical_mps,
                                kMinimumJerkPeakSpeed * 0.1 / kRunS},
                      LimitCase{"horizontal acceleration", &RobotProfile::max_accel_horizontal_mps2,
                                kMinimumJerkPeakAcceleration* kRunM / (kRunS * kRunS)},
                      LimitCase{"vertical acceleration", &RobotProfile::max_accel_vertical_mps2,
                                kMinimumJerkPeakAcceleration * 0.1 / (kRunS * kRunS)}),
    NamedByQuantity<LimitCase>);

TEST(VerifyTrajectory, RefusesFloatingAboveOrSinkingBelowTheReferenceHeight) {
  const RobotProfile profile = Loose("differential");
  const VerifierConfig config;
  // The yard is no voxel lattice, so the configured tolerance is the one applied.
  ASSERT_LT(0.75 * Model().summary().vertical_quantum_m, config.ground_tolerance_m);
  const double tolerance = config.ground_tolerance_m;
  for (const double sign : {1.0, -1.0}) {
    ExpectRefused(Verify(profile, AcrossTheFloor(profile, 0, sign * (tolerance + kMarginM))),
                  "distance from the reference height above ground");
    ExpectPasses(Verify(profile, AcrossTheFloor(profile, 0, sign * (tolerance - kMarginM))));
  }
}

TEST(VerifyTrajectory, RefusesLeavingTheGround) {
  const RobotProfile profile = Loose("differential");
  // Over the hole in the floor, and off the map.
  ExpectRefused(Verify(profile, Along(profile, {3, 5}, {1.5, 5})), "no ground");
  ExpectPasses(Verify(profile, Along(profile, {3, 5}, {2.15, 5})));
  ExpectRefused(Verify(profile, Along(profile, {11, 0.5}, {15, 0.5})), "no ground");
}

TEST(VerifyTrajectory, RefusesAReferencePointAboveTheMapsGrid) {
  const RobotProfile profile = Loose("differential");
  const GridGeometry& grid = Model().grid();
  const double top = grid.origin_m.z() + grid.size.z() * grid.resolution_m;
  ExpectRefused(Verify(profile, MinimumJerk(Eigen::Vector3d(1, 1, top + kMarginM),
                                            Eigen::Vector3d(2, 1, top + kMarginM), 4)),
                "outside the map's grid");
}

// Beside the ramp's low side the floor is not valid ground: the ramp's edge rises steeply
// within the filter's radius. Half a metre further out it is.
TEST(VerifyTrajectory, RefusesGroundTheValidGroundFilterRemoved) {
  const RobotProfile profile = Loose("differential");
  ExpectRefused(Verify(profile, Along(profile, {7.6, 5.15}, {8.2, 5.15})), "not valid ground");
  ExpectPasses(Verify(profile, Along(profile, {7.6, 5.6}, {8.2, 5.6})));
}

TEST(VerifyTrajectory, RefusesATrajectoryTooFastToSampleDensely) {
  const RobotProfile profile = Loose("differential");
  // 1.9e6 m/s at its peak: 1e8 samples 2 cm apart.
  ExpectRefused(Verify(profile, test_util::FloorMotion(profile, {1, 1}, {1e6, 1}, 1)), "too many");
}

TEST(VerifyTrajectory, RefusesComingCloserToAnObstacleThanTheBound) {
  const RobotProfile profile = Loose("differential");
  const Trajectory trajectory = AcrossTheFloor(profile);
  VerifierConfig config;
  config.min_obstacle_distance_m = 0;
  VerificationReport report;
  ExpectPasses(Verify(profile, trajectory, config, &report));
  // The floor itself is the nearest obstacle: about the reference height away.
  const double distance = report.min_obstacle_distance_m;
  EXPECT_NEAR(distance, profile.reference_height_m, 0.05);
  config.min_obstacle_distance_m = distance + kMarginM;
  ExpectRefused(Verify(profile, trajectory, config), "obstacle distance");
  config.min_obstacle_distance_m = distance - kMarginM;
  ExpectPasses(Verify(profile, trajectory, config));
}

TEST(VerifyTrajectory, RefusesGroundSteeperThanTheProfileAllows) {
  RobotProfile profile = Loose("differential");
  const auto on_ramp = [&](double x) {
    return Eigen::Vector3d(x, 3,
                           (x - 7) * std::tan(kYardRampSlopeRad) + profile.reference_height_m);
  };
  const Trajectory up_the_ramp = MinimumJerk(on_ramp(7.6), on_ramp(9.4), 6);
  VerificationReport report;
  ExpectPasses(Verify(profile, up_the_ramp, {}, &report));
  const double tilt = report.max_tilt_rad;  // The plane fits' tilt, near the ramp's 10°.
  EXPECT_NEAR(tilt, kYardRampSlopeRad, 0.01);
  profile.max_tilt_rad = tilt - 0.002;
  ExpectRefused(Verify(profile, up_the_ramp), "ground tilt");
  profile.max_tilt_rad = tilt + 0.002;
  ExpectPasses(Verify(profile, up_the_ramp));
}

TEST(VerifyTrajectory, RefusesABodyHeightOutsideItsRange) {
  const RobotProfile biped = Loose("biped");
  const double tolerance = BodyHeightTolerance(biped, {});
  EXPECT_NEAR(tolerance, 0.007, 1e-12);  // 1% of the biped's 0.7 m.
  const double high = biped.body_height_max_m + tolerance,
               low = biped.body_height_min_m - tolerance;
  ExpectRefused(Verify(biped, AcrossTheFloor(biped, 0, 0, high + kMarginM)), "body height");
  ExpectPasses(Verify(biped, AcrossTheFloor(biped, 0, 0, high - kMarginM)));
  ExpectRefused(Verify(biped, AcrossTheFloor(biped, 0, 0, low - kMarginM)), "body height");
  ExpectPasses(Verify(biped, AcrossTheFloor(biped, 0, 0, low + kMarginM)));
}

// Under the slab, from x = 2.5 to 3.5 at y = 3 (0.5 m inside its edges).
Trajectory UnderTheSlab(const RobotProfile& profile, double body_m = 0) {
  return test_util::FloorMotion(profile, {2.5, 3}, {3.5, 3}, 4, {.body_m = body_m});
}

// The floor's ceiling under the slab, read from the map.
double SlabClearance() {
  for (const ColumnSurface& s : Model().surfaces().Column(Model().grid().CellOf({3, 3, 0}).x(),
                                                          Model().grid().CellOf({3, 3, 0}).y())) {
    if (std::abs(s.ground_z_m) < 0.01) return s.clearance_m;
  }
  return 0;
}

TEST(VerifyTrajectory, KeepsTheProfilesHeadroomAboveTheCommandedBody) {
  const RobotProfile biped = Loose("biped");
  const VerifierConfig config;
  const double clearance = SlabClearance();
  ASSERT_NEAR(clearance, 0.45, 1e-6);
  // The body may eat into the headroom by the stated tolerance (1% of the highest body), no
  // more.
  const double highest =
      clearance - biped.headroom_m + config.limit_tolerance * biped.body_height_max_m;
  ExpectRefused(Verify(biped, UnderTheSlab(biped, highest + kMarginM), config), "headroom");
  VerificationReport report;
  ExpectPasses(Verify(biped, UnderTheSlab(biped, highest - kMarginM), config, &report));
  EXPECT_NEAR(report.min_headroom_m, clearance - (highest - kMarginM), 1e-6);
}

// The body comes down while the robot drives 2 cm across the slab's edge in 1 s: the
// samples 2 cm apart fall on either side of the edge, where the body fits, and only the state
// at the edge itself (body 0.415 m under a ceiling that allows 0.407 m) breaks the headroom.
TEST(VerifyTrajectory, ChecksTheHeadroomWhereTheBodyEntersUnderTheCeiling) {
  const RobotProfile biped = Loose("biped");
  const GridGeometry& grid = Model().grid();
  // The slab's first column along y = 3.
  double edge = 0;
  for (int ix = 0; ix < grid.size.x() && edge == 0; ++ix) {
    for (const ColumnSurface& s : Model().surfaces().Column(ix, grid.CellOf({0, 3, 0}).y())) {
      if (s.clearance_m < 1) edge = grid.origin_m.x() + ix * grid.resolution_m;
    }
  }
  ASSERT_NEAR(edge, 2.0, 0.1);
  const double z = biped.reference_height_m;
  const auto entering = [&](double body_from_m) {
    return MinimumJerk(Eigen::Vector4d(edge - 0.01, 3, z, body_from_m),
                       Eigen::Vector4d(edge + 0.01, 3, z, 0.36), 1);
  };
  // At the edge (halfway in time and space) the body is halfway between its ends.
  ExpectRefused(Verify(biped, entering(0.47)), "headroom");
  ExpectPasses(Verify(biped, entering(0.44)));
}

// Between the samples. Each trajectory below breaks its rule only between the instants a
// sampled check would look at (samples 2 cm apart along the path, column entries; with the
// spacing raised where the rule changes over more than 2 cm), and is refused; the same
// trajectory kept just inside the bound passes.

// `trajectory` (one piece) with a bump added on `axis`: h·16 s²(1 − s)², s = t / T, 0 with zero
// slope at both ends and h at s = 1/2.
Trajectory WithBump(Trajectory trajectory, int axis, double h) {
  TrajectoryPiece& piece = trajectory.pieces.at(0);
  const double T = piece.duration_s;
  piece.coefficients(2, axis) += 16 * h / (T * T);
  piece.coefficients(3, axis) += -32 * h / (T * T * T);
  piece.coefficients(4, axis) += 16 * h / (T * T * T * T);
  return trajectory;
}

// Standing still at (x, y) for 2 s, the reference point at the reference height.
Trajectory Standing(const RobotProfile& profile, double x, double y, double body_m = 0.65) {
  return test_util::FloorMotion(profile, {x, y}, {x, y}, 2, {.body_m = body_m});
}

// A 2 cm nudge in 1 s: samples 2 cm apart fall at s = 0, 1/3, 2/3 and 1, where the speed is
// 79% of its peak (s = 1/2) and the acceleration at most 77% of its (s = 1/2 ∓ √3/6). The bound
// is set between the sampled and the true peak (refused), then just above the peak (passes).
struct PeakCase {
  const char* quantity;
  double RobotProfile::*bound;
  double peak;               // Over the nudge.
  double below_peak_factor;  // The refused bound, as a fraction of peak / allowed.
};

class VerifyPeaksBetweenSamples : public ::testing::TestWithParam<PeakCase> {};

TEST_P(VerifyPeaksBetweenSamples, RefusesAPeakBetweenTwoSamples) {
  const PeakCase& c = GetParam();
  RobotProfile profile = Loose("differential");
  const double z = profile.reference_height_m;
  const Trajectory nudge =
      MinimumJerk(Eigen::Vector3d(1.03, 1.05, z), Eigen::Vector3d(1.05, 1.05, z), 1);
  const double allowed = 1 + VerifierConfig{}.limit_tolerance;
  profile.*c.bound = c.peak / allowed * c.below_peak_factor;
  ExpectRefused(Verify(profile, nudge), c.quantity);
  profile.*c.bound = c.peak / allowed * (1 + kRelativeMargin);
  ExpectPasses(Verify(profile, nudge));
}

INSTANTIATE_TEST_SUITE_P(
    SpeedAndAcceleration, VerifyPeaksBetweenSamples,
    ::testing::Values(PeakCase{"horizontal speed", &RobotProfile::max_speed_horizontal_mps,
                               kMinimumJerkPeakSpeed * 0.02, 0.95},
                      PeakCase{"horizontal acceleration", &RobotProfile::max_accel_horizontal_mps2,
                               kMinimumJerkPeakAcceleration * 0.02, 0.9}),
    NamedByQuantity<PeakCase>);

// Standing still, the biped stretches above its highest body height for a moment: only the
// two ends are sampled.
TEST(VerifyBetweenSamples, RefusesTheBodyLeavingItsRangeBetweenTwoSamples) {
  const RobotProfile biped = Loose("biped");
  const double highest = biped.body_height_max_m + BodyHeightTolerance(biped, {});
  const double rest = 0.6;
  ExpectRefused(
      Verify(biped, WithBump(Standing(biped, 1.05, 1.05, rest), 3, highest + kMarginM - rest)),
      "body height");
  ExpectPasses(
      Verify(biped, WithBump(Standing(biped, 1.05, 1.05, rest), 3, highest - kMarginM - rest)));
}

// The biped stands under the slab and raises its body for a moment: no sample but the two
// ends (it does not move), where the body is low.
TEST(VerifyBetweenSamples, RefusesTheBodyRisingIntoTheHeadroomBetweenTwoSamples) {
  const RobotProfile biped = Loose("biped");
  const double highest = SlabClearance() - biped.headroom_m + BodyHeightTolerance(biped, {});
  const double low = 0.36;
  ExpectRefused(Verify(biped, WithBump(Standing(biped, 3, 3, low), 3, highest + kMarginM - low)),
                "headroom");
  ExpectPasses(Verify(biped, WithBump(Standing(biped, 3, 3, low), 3, highest - kMarginM - low)));
}

// The robot dips 4 cm towards the floor, its nearest obstacle, and comes back up, with
// samples 0.5 m apart: only the two ends are sampled.
TEST(VerifyBetweenSamples, RefusesComingCloserToAnObstacleBetweenTwoSamples) {
  const RobotProfile profile = Loose("differential");
  const Trajectory dip = WithBump(Standing(profile, 1.05, 1.05), 2, -0.04);
  double closest = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= 20000; ++k) {
    closest = std::min(closest, Model().Distance(dip.Evaluate(2.0 * k / 20000, 0).head<3>()));
  }
  VerifierConfig config;
  config.max_sample_spacing_m = 0.5;
  ASSERT_LT(closest, Model().Distance(dip.Evaluate(0, 0).head<3>()) - 0.03);
  config.min_obstacle_distance_m = closest + kMarginM;
  ExpectRefused(Verify(profile, dip, config), "obstacle distance");
  config.min_obstacle_distance_m = closest - kMarginM;
  ExpectPasses(Verify(profile, dip, config));
}

// Standing still, the robot bobs up (or down) past the ground tolerance and back, with
// samples 0.5 m apart: only the two ends are sampled. The tolerance is tightened to 3 cm so
// that the level rule, whose tolerance is 2.6 cm wider, holds over the whole bob and splits
// nothing.
TEST(VerifyBetweenSamples, RefusesLeavingTheReferenceHeightBetweenTwoSamples) {
  const RobotProfile profile = Loose("differential");
  VerifierConfig config;
  config.max_sample_spacing_m = 0.5;
  config.ground_tolerance_m = 0.03;
  const double tolerance = config.ground_tolerance_m;
  for (const double sign : {1.0, -1.0}) {
    SCOPED_TRACE(sign > 0 ? "up" : "down");
    const Trajectory standing = Standing(profile, 1.05, 1.05);
    ExpectRefused(Verify(profile, WithBump(standing, 2, sign * (tolerance + kMarginM)), config),
                  "distance from the reference height above ground");
    ExpectPasses(Verify(profile, WithBump(standing, 2, sign * (tolerance - kMarginM)), config));
  }
}

// A zone hangs over the robot; it rises 5 cm towards it and back, with samples 0.5 m apart.
TEST(VerifyBetweenSamples, RefusesReachingIntoAKeepOutZoneBetweenTwoSamples) {
  const RobotProfile profile = Loose("differential");
  const Trajectory lift = WithBump(Standing(profile, 1.05, 1.05), 2, 0.05);
  VerifierConfig config;
  config.max_sample_spacing_m = 0.5;
  // The robot's top at rest: its ground plus its highest body.
  const double top = std::max(profile.MaxBodyHeight(), profile.reference_height_m);
  const auto zone_from = [&](double bottom_m) {
    Prism prism;
    prism.polygon_m = {{0.8, 0.8}, {1.3, 0.8}, {1.3, 1.3}, {0.8, 1.3}};
    prism.z_min_m = bottom_m;
    prism.z_max_m = bottom_m + 1;
    return std::vector<KeepOutZone>{KeepOutZone(prism, "the hanging zone")};
  };
  VerificationReport report;
  const SurfaceGraph graph = GraphFor(profile);
  ExpectRefused(VerifyTrajectory(graph, profile, lift, config, &report, zone_from(top + 0.03)),
                "the hanging zone");
  ExpectPasses(
      VerifyTrajectory(graph, profile, lift, config, &report, zone_from(top + 0.05 + kMarginM)));
}

// A post 0.5 m tall on a floor, assessed with a ground filter radius so small that the floor
// right beside it stays valid: the post's column holds one surface, the post's top. A robot
// driving through the post stands on no ground of its own column at its level, although the
// smoothed ground around (and the obstacle distance a few centimetres off the post's axis)
// look fine.
TEST(VerifyTrajectory, RefusesAColumnWhoseOnlyGroundIsAnotherLevel) {
  static const std::shared_ptr<const TerrainModel> model = [] {
    test_util::CloudBuilder b(0.05);
    b.Plate(0, 4, 0, 4, 0).Block(2, 2, 2, 2, 0.05, 0.5);
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    config.ground.radius_m = 0.05;
    return TerrainModel::Assess(b.cloud(), config).value();
  }();
  const RobotProfile profile = Loose("differential");
  const SurfaceGraph graph = SurfaceGraph::Build(*model, profile.Traversability()).value();
  const Eigen::Vector3i post = model->grid().CellOf({2, 2, 0});
  ASSERT_EQ(model->surfaces().Column(post.x(), post.y()).size(), 1u);
  const auto along = [&](double y) { return Along(profile, {1.5, y}, {2.5, y}); };
  // The smoothed ground rises towards the post's top, past the default ground tolerance a
  // centimetre before the post's column; with a looser one the level rule alone must refuse.
  VerifierConfig config;
  config.ground_tolerance_m = 0.3;
  VerificationReport report;
  ExpectRefused(VerifyTrajectory(graph, profile, along(2.0), {}, &report),
                "distance from the reference height above ground");
  ExpectRefused(VerifyTrajectory(graph, profile, along(2.0), config, &report),
                "no ground in the column below at the robot's level");
  ExpectPasses(VerifyTrajectory(graph, profile, along(2.3), config, &report));
}

// A robot of fixed height too tall for the passage under the slab: its graph has no node on
// the floor there, but one on the slab above, within the level gap of the floor. The
// verifier judges the floor it drives on, not the deck over its head.
TEST(VerifyTrajectory, JudgesTheLevelTheRobotDrivesOnNotTheDeckAboveIt) {
  RobotProfile profile = Loose("differential");
  const double clearance = SlabClearance();
  profile.body_height_m = clearance - profile.headroom_m + 0.01;
  const SurfaceGraph graph = GraphFor(profile);
  const Eigen::Vector3i cell = Model().grid().CellOf({3, 3, 0});
  ASSERT_EQ(graph.ColumnNodes(cell.x(), cell.y()).size(), 1u);
  ASSERT_NEAR(graph.ground_z(graph.ColumnNodes(cell.x(), cell.y())[0]), 0.45, 1e-6)
      << "the slab's top must be the column's only node";
  ASSERT_LT(0.45, SurfaceGraph::kLevelGapM);
  ExpectRefused(Verify(profile, UnderTheSlab(profile)), "ceiling (0.450 m above ground)");

  profile.body_height_m = clearance - profile.headroom_m - 0.01;
  ExpectPasses(Verify(profile, UnderTheSlab(profile)));
}

TEST(VerifyTrajectory, RefusesGroundThatIsNoNodeOfTheGraphItIsGiven) {
  RobotProfile fits = Loose("differential");
  fits.body_height_m = SlabClearance() - fits.headroom_m - 0.01;
  RobotProfile too_tall = fits;
  too_tall.body_height_m += 0.02;
  const Trajectory trajectory = UnderTheSlab(fits);
  VerificationReport report;
  // The same trajectory, checked against a graph built for a taller robot.
  const Status refused =
      VerifyTrajectory(GraphFor(too_tall), fits, trajectory, VerifierConfig{}, &report);
  ExpectRefused(refused, "not a node of the traversability graph");
  ExpectPasses(VerifyTrajectory(GraphFor(fits), fits, trajectory, VerifierConfig{}, &report));
}

TEST(VerifyTrajectory, RefusesNonFiniteCoefficientsAndBadDurations) {
  const RobotProfile biped = Loose("biped");
  const Trajectory clean = AcrossTheFloor(biped);
  ExpectPasses(Verify(biped, clean));
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    for (std::size_t piece = 0; piece < clean.pieces.size(); ++piece) {
      for (int axis = 0; axis < 4; ++axis) {
        for (const int order : {0, 3, 5}) {
          Trajectory t = clean;
          t.pieces[piece].coefficients(order, axis) = bad;
          SCOPED_TRACE("piece " + std::to_string(piece) + " axis " + std::to_string(axis) +
                       " order " + std::to_string(order));
          ExpectRefused(Verify(biped, t), "non-finite coefficients");
        }
      }
    }
  }
  for (const double duration : {std::nan(""), 0.0, -1.0, std::numeric_limits<double>::infinity()}) {
    Trajectory t = clean;
    t.pieces.back().duration_s = duration;
    ExpectRefused(Verify(biped, t), "duration");
  }
  ExpectRefused(Verify(biped, Trajectory{4, {}}), "no pieces");
}

TEST(VerifyTrajectory, RefusesATrajectoryOfTheWrongDimensionForTheProfile) {
  const RobotProfile biped = Loose("biped"), differential = Loose("differential");
  VerificationReport report;
  Status status = Verify(biped, AcrossTheFloor(differential));
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(status.error().message, HasSubstr("dimension 3 but profile 'biped' needs 4"));
  status = Verify(differential, AcrossTheFloor(biped));
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidInput);
  Trajectory ragged = AcrossTheFloor(biped);
  ragged.pieces[1].coefficients.conservativeResize(6, 3);
  status = Verify(biped, ragged);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(status.error().message, HasSubstr("piece 1 has 3 axes"));
}

TEST(VerifyTrajectory, RefusesABadConfigOrProfileBeforeSampling) {
  const RobotProfile profile = Loose("differential");
  VerifierConfig config;
  config.max_sample_spacing_m = 0;
  Status status = Verify(profile, AcrossTheFloor(profile), config);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(status.error().message, HasSubstr("verifier.max_sample_spacing_m"));
  RobotProfile broken = profile;
  broken.max_speed_vertical_mps = std::nan("");
  VerificationReport report;
  status = VerifyTrajectory(GraphFor(profile), broken, AcrossTheFloor(profile), {}, &report);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(status.error().message, HasSubstr("profile.max_speed_vertical_mps"));
}

// Each field of VerifierConfig, set out of its range, is named by Validate.
struct ConfigField {
  const char* name;
  double VerifierConfig::*field;
  std::vector<double> bad;
};

TEST(VerifierConfig, ValidateNamesEachFieldOutOfRange) {
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  const ConfigField fields[] = {
      {"verifier.max_sample_spacing_m", &VerifierConfig::max_sample_spacing_m, {0, -1, nan, inf}},
      {"verifier.ground_tolerance_m", &VerifierConfig::ground_tolerance_m, {0, -1, nan, inf}},
      {"verifier.min_obstacle_distance_m",
       &VerifierConfig::min_obstacle_distance_m,
       {-1e-3, nan, inf}},
      {"verifier.limit_tolerance", &VerifierConfig::limit_tolerance, {-1e-3, nan, inf}},
  };
  EXPECT_TRUE(VerifierConfig{}.Validate().ok());
  for (const ConfigField& f : fields) {
    for (const double value : f.bad) {
      VerifierConfig config;
      config.*f.field = value;
      const Status status = config.Validate();
      ASSERT_FALSE(status.ok()) << f.name << " = " << value;
      EXPECT_EQ(status.error().code, ErrorCode::kInvalidConfig);
      EXPECT_THAT(status.error().message, HasSubstr(std::string(f.name) + " = "));
    }
  }
  // The edges of the ranges are valid.
  VerifierConfig edges;
  edges.min_obstacle_distance_m = 0;
  edges.limit_tolerance = 0;
  EXPECT_TRUE(edges.Validate().ok());
}

// Fleet traffic: the trajectory across the floor (x 1 → 4 at y = 1 in 4 s) against another
// robot parked at `parked_at` over [parked_from_s, parked_until_s] after the departure.
Status VerifyAmongTraffic(const RobotProfile& profile, const Eigen::Vector3d& parked_at,
                          double parked_from_s, double parked_until_s) {
  constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;
  ReservedMotion other;
  other.robot_id = "R7";
  other.motion.start_ns = AddSeconds(kDeparture, parked_from_s);
  TrajectoryPiece stand;
  stand.duration_s = parked_until_s - parked_from_s;
  stand.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  stand.coefficients.row(0) = parked_at.transpose();
  other.motion.trajectory.pieces.push_back(stand);
  other.motion.end_ns = other.motion.ArrivalNs();
  const std::vector<ReservedMotion> others = {other};
  Traffic traffic;
  traffic.departure_ns = kDeparture;
  traffic.parked_until_ns = AddSeconds(kDeparture, kRunS);
  traffic.body = FleetBody::FromProfile(profile);
  traffic.others = others;
  VerificationReport report;
  return VerifyTrajectory(GraphFor(profile), profile, AcrossTheFloor(profile), {}, &report, {},
                          &traffic);
}

TEST(VerifyTrajectory, ATrajectoryThatMeetsAnotherRobotIsRefusedNamingIt) {
  const RobotProfile profile = Loose("differential");
  const double z = profile.reference_height_m;
  // Parked on the way from 1 s to 3 s: the trajectory reaches it.
  const Status met = VerifyAmongTraffic(profile, {2.5, 1.2, z}, 1.0, 3.0);
  ASSERT_FALSE(met.ok());
  EXPECT_EQ(met.error().code, ErrorCode::kReservationConflict);
  EXPECT_THAT(met.error().message, HasSubstr("robot 'R7'"));
  EXPECT_EQ(met.error().details.at("robot_id"), "R7");
  // The same place, but gone before the robot comes (it is at x = 2.5 after 2 s), beside
  // the way (0.8 m from it; the two radii and the separation need 0.7 m), or under the floor.
  ExpectPasses(VerifyAmongTraffic(profile, {2.5, 1.2, z}, 0.0, 1.0));
  ExpectPasses(VerifyAmongTraffic(profile, {2.5, 1.8, z}, 0.0, 4.0));
  ExpectPasses(VerifyAmongTraffic(profile, {2.5, 1.2, z - 3.0}, 0.0, 4.0));
}

}  // namespace
}  // namespace strata
