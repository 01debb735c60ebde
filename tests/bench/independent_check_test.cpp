// The benchmark's own check (oracle/independent_check.hpp) on hand-made trajectories over the
// hand-made yard (test_util::Yard): a clean trajectory breaks no rule, and each rule counts
// the trajectory that breaks it, and no other rule.
#include "independent_check.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util/hand_made_maps.hpp"
#include "test_util/trajectory_builders.hpp"
#include "verifier_bounds.hpp"

namespace strata::bench {
namespace {

using test_util::kMinimumJerkPeakAcceleration;
using test_util::kMinimumJerkPeakSpeed;
using test_util::LooseProfile;
using test_util::MinimumJerk;

// Rest to rest along the floor at y = 1 from x = 1 to 4 in 4 s, rising 0.1 m around the
// reference height; active-height robots hold the body at `body_m`.
constexpr double kRunM = 3, kRunS = 4, kRiseM = 0.1;
Trajectory AcrossTheFloor(const RobotProfile& profile, double offset_m = 0, double body_m = 0.65) {
  return test_util::FloorMotion(profile, {1, 1}, {1 + kRunM, 1}, kRunS,
                                {kRiseM, offset_m, body_m, 2});
}

IndependentCheckCounts Check(const RobotProfile& profile, const Trajectory& trajectory,
                             const IndependentCheckConfig& config = CheckConfigFor({})) {
  return CheckTrajectory(test_util::YardModel(), profile, trajectory, config);
}

// The rules a count broke, by name, for readable expectations.
std::string Broken(const IndependentCheckCounts& c) {
  std::string names;
  const std::pair<const char*, int> rules[] = {
      {"ground", c.ground},           {"clearance", c.clearance}, {"headroom", c.headroom},
      {"body_height", c.body_height}, {"speed", c.speed},         {"acceleration", c.acceleration},
      {"keep_out", c.keep_out}};
  for (const auto& [name, count] : rules) {
    if (count > 0) names += std::string(names.empty() ? "" : " ") + name;
  }
  return names;
}

TEST(IndependentCheck, ACleanTrajectoryBreaksNoRuleAndIsSampledDensely) {
  const RobotProfile profile = LooseProfile("differential");
  const IndependentCheckCounts counts = Check(profile, AcrossTheFloor(profile));
  EXPECT_EQ(Broken(counts), "");
  EXPECT_FALSE(counts.Any());
  // Every centimetre of the 3 m, every millisecond of the 4 s.
  EXPECT_GE(counts.map_samples, kRunM / 0.01);
  EXPECT_GE(counts.motion_samples, kRunS / 0.001);
}

TEST(IndependentCheck, CountsSpeedAndAccelerationJustOverTheirBounds) {
  const double allowed = 1 + VerifierConfig{}.limit_tolerance;
  const struct {
    double RobotProfile::*bound;
    double peak;
    const char* rule;
  } cases[] = {
      {&RobotProfile::max_speed_horizontal_mps, kMinimumJerkPeakSpeed * kRunM / kRunS, "speed"},
      {&RobotProfile::max_speed_vertical_mps, kMinimumJerkPeakSpeed * kRiseM / kRunS, "speed"},
      {&RobotProfile::max_accel_horizontal_mps2,
       kMinimumJerkPeakAcceleration * kRunM / (kRunS * kRunS), "acceleration"},
      {&RobotProfile::max_accel_vertical_mps2,
       kMinimumJerkPeakAcceleration * kRiseM / (kRunS * kRunS), "acceleration"},
  };
  for (const auto& c : cases) {
    RobotProfile profile = LooseProfile("differential");
    profile.*c.bound = c.peak / allowed * 0.997;
    EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile))), c.rule);
    profile.*c.bound = c.peak / allowed * 1.003;
    EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile))), "");
  }
}

TEST(IndependentCheck, CountsABodyHeightOutsideItsRange) {
  const RobotProfile biped = LooseProfile("biped");
  const double tolerance = BodyHeightTolerance(biped, VerifierConfig{});
  const double high = biped.body_height_max_m + tolerance;
  EXPECT_EQ(Broken(Check(biped, AcrossTheFloor(biped, 0, high + 0.002))), "body_height");
  EXPECT_EQ(Broken(Check(biped, AcrossTheFloor(biped, 0, high - 0.002))), "");
  const double low = biped.body_height_min_m - tolerance;
  EXPECT_EQ(Broken(Check(biped, AcrossTheFloor(biped, 0, low - 0.002))), "body_height");
  EXPECT_EQ(Broken(Check(biped, AcrossTheFloor(biped, 0, low + 0.002))), "");
}

TEST(IndependentCheck, CountsGroundTooFarBelowTheReferencePoint) {
  const RobotProfile profile = LooseProfile("differential");
  // The ground tolerance plus the rise across a 0.1 m cell's diagonal at the profile's 20°,
  // less the half rise at the trajectory's ends.
  const double tolerance = VerifierConfig{}.ground_tolerance_m +
                           0.1 * std::sqrt(2.0) * std::tan(profile.max_tilt_rad) - kRiseM / 2;
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile, tolerance + 0.003))), "ground");
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile, tolerance - 0.003))), "");
}

TEST(IndependentCheck, CountsNoGroundInvalidGroundAndSteepGround) {
  RobotProfile profile = LooseProfile("differential");
  const double z = profile.reference_height_m;
  // Over the hole in the floor (no headroom can be judged there either).
  EXPECT_EQ(Broken(Check(profile, test_util::FloorMotion(profile, {3, 5}, {1.5, 5}, 4))),
            "ground headroom");
  // Beside the ramp's low side, where the ground filter removed the floor.
  EXPECT_EQ(Broken(Check(profile, test_util::FloorMotion(profile, {7.6, 5.15}, {8.2, 5.15}, 4))),
            "ground");
  // Up the 10° ramp, for a robot allowed 9.5°, then 10.5°.
  const auto on_ramp = [&](double x) {
    return Eigen::Vector3d(x, 3, (x - 7) * std::tan(test_util::kYardRampSlopeRad) + z);
  };
  const Trajectory up = MinimumJerk(on_ramp(7.6), on_ramp(9.4), 6);
  profile.max_tilt_rad = test_util::kYardRampSlopeRad - 0.5 * std::numbers::pi / 180;
  EXPECT_EQ(Broken(Check(profile, up)), "ground");
  profile.max_tilt_rad = test_util::kYardRampSlopeRad + 0.5 * std::numbers::pi / 180;
  EXPECT_EQ(Broken(Check(profile, up)), "");
}

TEST(IndependentCheck, CountsAnObstacleCloserThanTheBound) {
  const RobotProfile profile = LooseProfile("differential");
  IndependentCheckConfig config = CheckConfigFor({});
  // The floor is the nearest obstacle, 0.25-0.35 m below the reference point.
  config.bounds.min_obstacle_distance_m = 0.4;
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile), config)), "clearance");
  config.bounds.min_obstacle_distance_m = 0.2;
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile), config)), "");
}

TEST(IndependentCheck, CountsABodyThatEatsIntoTheHeadroomUnderTheSlab) {
  const RobotProfile biped = LooseProfile("biped");
  // Under the slab (its underside 0.45 m above the floor): at most 0.45 − 0.05 + 0.007.
  const auto under = [&](double body_m) {
    return test_util::FloorMotion(biped, {2.5, 3}, {3.5, 3}, 4, {.body_m = body_m});
  };

  EXPECT_EQ(Broken(Check(biped, under(0.409))), "headroom");
  EXPECT_EQ(Broken(Check(biped, under(0.405))), "");
  // A robot of fixed height 0.5 m on the floor under the slab, whose top is another level.
  const RobotProfile differential = LooseProfile("differential");
  EXPECT_EQ(
      Broken(Check(differential, test_util::FloorMotion(differential, {2.5, 3}, {3.5, 3}, 4))),
      "headroom");
}

TEST(IndependentCheck, ABrokenTrajectoryBreaksEveryRule) {
  const RobotProfile profile = LooseProfile("differential");
  Trajectory t = AcrossTheFloor(profile);
  t.pieces[1].coefficients(2, 0) = std::nan("");
  EXPECT_EQ(Broken(Check(profile, t)),
            "ground clearance headroom body_height speed acceleration keep_out");
  EXPECT_EQ(Broken(Check(profile, Trajectory{})),
            "ground clearance headroom body_height speed acceleration keep_out");
  EXPECT_EQ(Broken(Check(LooseProfile("biped"), AcrossTheFloor(profile))),
            "ground clearance headroom body_height speed acceleration keep_out");
}

// A zone beside the way across the floor (y = 1): the footprint (radius 0.3 m) reaches a
// polygon 0.29 m away and not one 0.31 m away; a zone above the robot's top is no obstacle.
TEST(IndependentCheck, CountsTheFootprintReachingIntoAKeepOutZone) {
  const RobotProfile profile = LooseProfile("differential");
  const double top = std::max(profile.MaxBodyHeight(), profile.reference_height_m);
  const auto beside = [&](double gap_m, double bottom_m) {
    IndependentCheckConfig config = CheckConfigFor({});
    Prism zone;
    const double y = 1 + gap_m;
    zone.polygon_m = {{2, y}, {3, y}, {3, y + 1}, {2, y + 1}};
    zone.z_min_m = bottom_m;
    zone.z_max_m = bottom_m + 2;
    config.keep_out = {zone};
    return config;
  };
  const double ground = -1;  // Below the floor: the zone spans the robot's whole height.
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile), beside(0.29, ground))), "keep_out");
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile), beside(0.31, ground))), "");
  // The way rises 0.1 m around the reference height: the robot's top reaches top + 0.05.
  EXPECT_EQ(Broken(Check(profile, AcrossTheFloor(profile), beside(0.29, top + kRiseM))), "");
}

TEST(IndependentCheck, TheTallyCountsPlansPerRuleAndTheCsvKeepsItsOrder) {
  IndependentCheckTally tally;
  IndependentCheckCounts clean, broken;
  broken.headroom = 3;
  broken.speed = 1;
  tally.Add(clean);
  tally.Add(broken);
  tally.Add(broken);
  EXPECT_EQ(tally.Describe(),
            "3 checked: ground 0, clearance 0, headroom 2, body height 0, speed 2, acceleration 0, "
            "keep-out 0");
  EXPECT_EQ(IndependentCheckCsvHeader(),
            "check_ground,check_clearance,check_headroom,check_body_height,check_speed,"
            "check_acceleration,check_keep_out");
  EXPECT_EQ(IndependentCheckCsvValues(&broken), "0,0,3,0,1,0,0");
  EXPECT_EQ(IndependentCheckCsvValues(nullptr), "-1,-1,-1,-1,-1,-1,-1");
}

}  // namespace
}  // namespace strata::bench
