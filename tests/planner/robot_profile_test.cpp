// RobotProfile: every Validate branch names its field, the built-in profiles are what their
// documentation says, Traversability() carries the profile into the graph's terms, and
// CheckProfileFitsMap refuses both ways a map can be assessed too loosely for a robot.
#include "strata/planning/robot_profile.hpp"

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata {
namespace {

using ::testing::HasSubstr;

constexpr double kDegree = std::numbers::pi / 180;

RobotProfile Biped() { return BuiltinProfile("biped").value(); }
RobotProfile Differential() { return BuiltinProfile("differential").value(); }

struct Spoiled {
  std::string field;  // As Validate names it, after "profile.".
  std::function<void(RobotProfile*)> spoil;
  RobotProfile base;
};

TEST(RobotProfile, ValidateNamesTheFieldOfEveryBranch) {
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  const std::vector<Spoiled> cases = {
      {"footprint_radius_m", [](RobotProfile* p) { p->footprint_radius_m = 0; }, Differential()},
      {"footprint_radius_m", [&](RobotProfile* p) { p->footprint_radius_m = inf; }, Differential()},
      {"max_tilt_rad", [](RobotProfile* p) { p->max_tilt_rad = 0; }, Differential()},
      {"max_tilt_rad", [](RobotProfile* p) { p->max_tilt_rad = std::numbers::pi / 2; },
       Differential()},
      {"max_step_m", [](RobotProfile* p) { p->max_step_m = -0.01; }, Differential()},
      {"max_step_m", [&](RobotProfile* p) { p->max_step_m = nan; }, Differential()},
      {"reference_height_m", [](RobotProfile* p) { p->reference_height_m = 0; }, Differential()},
      {"max_speed_horizontal_mps", [](RobotProfile* p) { p->max_speed_horizontal_mps = -1; },
       Differential()},
      {"max_speed_vertical_mps", [&](RobotProfile* p) { p->max_speed_vertical_mps = nan; },
       Differential()},
      {"max_accel_horizontal_mps2", [](RobotProfile* p) { p->max_accel_horizontal_mps2 = 0; },
       Differential()},
      {"max_accel_vertical_mps2", [&](RobotProfile* p) { p->max_accel_vertical_mps2 = inf; },
       Differential()},
      {"headroom_m", [](RobotProfile* p) { p->headroom_m = -0.01; }, Differential()},
      {"body_height_m", [](RobotProfile* p) { p->body_height_m = 0; }, Differential()},
      {"body_height_min_m", [](RobotProfile* p) { p->body_height_min_m = 0; }, Biped()},
      {"body_height_max_m", [](RobotProfile* p) { p->body_height_max_m = 0.3; }, Biped()},
      // Active height: the preferred height within the range.
      {"body_height_m", [](RobotProfile* p) { p->body_height_m = 0.75; }, Biped()},
      // The reference point must not lie above the lowest body + headroom.
      {"reference_height_m", [](RobotProfile* p) { p->reference_height_m = 0.6; }, Differential()},
      {"reference_height_m", [](RobotProfile* p) { p->reference_height_m = 0.45; }, Biped()},
  };
  for (const Spoiled& c : cases) {
    RobotProfile profile = c.base;
    ASSERT_TRUE(profile.Validate().ok());
    c.spoil(&profile);
    const Status status = profile.Validate();
    ASSERT_FALSE(status.ok()) << c.field;
    EXPECT_EQ(status.error().code, ErrorCode::kInvalidConfig) << c.field;
    EXPECT_THAT(status.error().message, HasSubstr("profile." + c.field + " = ")) << c.field;
  }
}

TEST(RobotProfile, AFixedHeightIgnoresTheActiveRange) {
  RobotProfile profile = Differential();
  profile.body_height_min_m = -1;  // Unused without active height.
  profile.body_height_max_m = -2;
  EXPECT_TRUE(profile.Validate().ok());
  EXPECT_DOUBLE_EQ(profile.MinBodyHeight(), profile.body_height_m);
}

TEST(RobotProfile, TheBuiltInsAreWhatTheirDocumentationSays) {
  const std::vector<std::string> names = BuiltinProfileNames();
  EXPECT_EQ(names, (std::vector<std::string>{"differential", "biped"}));
  for (const std::string& name : names) {
    const Expected<RobotProfile> profile = BuiltinProfile(name);
    ASSERT_TRUE(profile.ok()) << name;
    EXPECT_EQ(profile->name, name);
    EXPECT_TRUE(profile->Validate().ok()) << name;
    EXPECT_DOUBLE_EQ(profile->footprint_radius_m, 0.3);
    EXPECT_DOUBLE_EQ(profile->max_speed_horizontal_mps, 1.0);
    EXPECT_DOUBLE_EQ(profile->max_accel_horizontal_mps2, 1.0);
    EXPECT_DOUBLE_EQ(profile->max_speed_vertical_mps, 0.5);
    EXPECT_DOUBLE_EQ(profile->max_accel_vertical_mps2, 0.5);
  }
  const RobotProfile differential = Differential();
  EXPECT_FALSE(differential.active_height);
  EXPECT_DOUBLE_EQ(differential.body_height_m, 0.5);
  EXPECT_DOUBLE_EQ(differential.reference_height_m, 0.3);
  EXPECT_NEAR(differential.max_tilt_rad, 20 * kDegree, 1e-12);
  const RobotProfile biped = Biped();
  EXPECT_TRUE(biped.active_height);
  EXPECT_DOUBLE_EQ(biped.reference_height_m, 0.2);
  EXPECT_DOUBLE_EQ(biped.body_height_min_m, 0.35);
  EXPECT_DOUBLE_EQ(biped.body_height_max_m, 0.7);
  EXPECT_DOUBLE_EQ(biped.body_height_m, 0.65);
  EXPECT_NEAR(biped.max_tilt_rad, 15 * kDegree, 1e-12);
  EXPECT_DOUBLE_EQ(biped.MinBodyHeight(), 0.35);

  const Expected<RobotProfile> unknown = BuiltinProfile("hexapod");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(unknown.error().message, HasSubstr("'hexapod'"));
  for (const std::string& name : names) EXPECT_THAT(unknown.error().message, HasSubstr(name));
}

TEST(RobotProfile, TraversabilityAsksForTheLowestBodyPlusHeadroom) {
  for (const RobotProfile& profile : {Differential(), Biped()}) {
    SCOPED_TRACE(profile.name);
    const TraversabilityParams t = profile.Traversability();
    EXPECT_DOUBLE_EQ(t.reference_height_m, profile.reference_height_m);
    EXPECT_DOUBLE_EQ(t.body_height_m, profile.MinBodyHeight() + profile.headroom_m);
    EXPECT_DOUBLE_EQ(t.max_tilt_rad, profile.max_tilt_rad);
    EXPECT_DOUBLE_EQ(t.max_step_m, profile.max_step_m);
    EXPECT_TRUE(t.Validate().ok());
  }
  // A valid profile always gives valid traversability parameters: the reference point lies
  // at most at the lowest body + headroom.
  RobotProfile edge = Biped();
  edge.reference_height_m = edge.body_height_min_m + edge.headroom_m;
  ASSERT_TRUE(edge.Validate().ok());
  EXPECT_TRUE(edge.Traversability().Validate().ok());
}

// kProfileMismatch with every piece of `expected` in its message.
void ExpectMismatch(const RobotProfile& profile, const AssessmentConfig& map,
                    const std::vector<std::string>& expected) {
  const Status status = CheckProfileFitsMap(profile, map);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kProfileMismatch);
  for (const std::string& text : expected) EXPECT_THAT(status.error().message, HasSubstr(text));
}

TEST(CheckProfileFitsMap, RefusesAMapFilteredForASmallerFootprintOrAGentlerSlope) {
  AssessmentConfig map;
  map.ground.radius_m = 0.3;
  map.ground.max_tilt_rad = 20 * kDegree;
  RobotProfile profile = Differential();
  EXPECT_TRUE(CheckProfileFitsMap(profile, map).ok());  // Equal is enough.

  profile.footprint_radius_m = 0.4;
  ExpectMismatch(profile, map,
                 {"footprint_radius_m = 0.4", "ground.radius_m = 0.3",
                  "a ground filter radius of at least 0.4 m"});
  profile = Differential();
  profile.max_tilt_rad = 25 * kDegree;
  ExpectMismatch(profile, map, {"(25.0 deg)", "(20.0 deg)", "a max tilt of at least 25.0 deg"});

  // A gentler robot on a steeper-filtered map, a smaller one on a wider-filtered map: fine.
  profile = Differential();
  profile.max_tilt_rad = 10 * kDegree;
  profile.footprint_radius_m = 0.2;
  EXPECT_TRUE(CheckProfileFitsMap(profile, map).ok());
}

}  // namespace
}  // namespace strata

namespace strata {
namespace {

// A start at 1e308 m is finite but on no map: it once got a 300-digit coordinate in a message
// that said there was no traversable ground there.
TEST(RobotState, RefusesCoordinatesNoMapReachesAndAbsurdMotionsNamingTheField) {
  RobotState state;
  EXPECT_TRUE(state.Validate("start").ok());
  state.position_m.x() = 1e308;
  Status s = state.Validate("start");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(s.error().field, "start.position_m.x");
  EXPECT_EQ(s.error().message, "start.position_m.x = 1e+308 m is beyond ±100000 m");
  state.position_m.x() = -kMaxAbsCoordinateM;  // The bound itself is allowed.
  EXPECT_TRUE(state.Validate("start").ok());
  state.velocity_mps.z() = std::nan("");
  s = state.Validate("goal");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "goal.velocity_mps.z");
  EXPECT_EQ(s.error().message, "goal.velocity_mps.z must be finite, got nan");
  state.velocity_mps.z() = 0;
  state.acceleration_mps2.y() = 2e3;
  s = state.Validate("start");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "start.acceleration_mps2.y");
}

}  // namespace
}  // namespace strata
