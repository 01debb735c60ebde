#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/scenes.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <numbers>
#include <random>
#include <string>

namespace strata {
namespace {

using ::testing::HasSubstr;

// The generators' documented jitter: at most 10% of the spacing across the lattice and at most
// min(5 mm, 10% of the spacing) in z.
constexpr double kRoomSpacingM = 0.05;
constexpr double kHallSpacingM = 0.1;
constexpr double kTerrainSpacingM = 0.1;
constexpr double kMaxJitterZM = 0.005;
// Slack for float storage of coordinates up to a few tens of metres.
constexpr double kFloatSlackM = 1e-4;

double MaxJitterXy(double spacing_m) { return 0.1 * spacing_m; }

using PointPredicate = std::function<bool(const Eigen::Vector3f&)>;

std::size_t CountIf(const PointCloud& cloud, const PointPredicate& pred) {
  return static_cast<std::size_t>(std::count_if(cloud.begin(), cloud.end(), pred));
}

bool InRange(double v, double lo, double hi) { return v >= lo && v <= hi; }

bool AllFinite(const PointCloud& cloud) {
  return std::all_of(cloud.begin(), cloud.end(),
                     [](const Eigen::Vector3f& p) { return p.allFinite(); });
}

// Every point lies in the box widened by the jitter.
void ExpectInBox(const PointCloud& cloud, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                 double spacing_m) {
  const double txy = MaxJitterXy(spacing_m) + kFloatSlackM;
  const double tz = kMaxJitterZM + kFloatSlackM;
  for (const Eigen::Vector3f& p : cloud) {
    ASSERT_TRUE(InRange(p.x(), lo.x() - txy, hi.x() + txy) &&
                InRange(p.y(), lo.y() - txy, hi.y() + txy) &&
                InRange(p.z(), lo.z() - tz, hi.z() + tz))
        << "point (" << p.transpose() << ") outside the documented bounds";
  }
}

// ---------------------------------------------------------------------------------------------
// Determinism, finiteness and size, for every scene.

struct SceneCase {
  std::string name;
  std::function<PointCloud(std::uint32_t)> generate;
};

std::vector<SceneCase> AllScenes() {
  return {{"stairs_ramp_room", [](std::uint32_t s) { return GenerateStairsRampRoom(s); }},
          {"two_level_ramp", [](std::uint32_t s) { return GenerateTwoLevelRamp(s); }},
          {"uneven_terrain", [](std::uint32_t s) { return GenerateUnevenTerrain(s); }}};
}

TEST(ScenesTest, SameSeedGivesIdenticalCloud) {
  for (const SceneCase& scene : AllScenes()) {
    SCOPED_TRACE(scene.name);
    const PointCloud a = scene.generate(7);
    const PointCloud b = scene.generate(7);
    ASSERT_FALSE(a.empty());
    EXPECT_TRUE(a == b);
  }
}

TEST(ScenesTest, DifferentSeedGivesDifferentCloud) {
  for (const SceneCase& scene : AllScenes()) {
    SCOPED_TRACE(scene.name);
    EXPECT_FALSE(scene.generate(1) == scene.generate(2));
  }
}

TEST(ScenesTest, EveryPointIsFiniteAndCountIsModerate) {
  for (const SceneCase& scene : AllScenes()) {
    SCOPED_TRACE(scene.name);
    const PointCloud cloud = scene.generate(3);
    EXPECT_TRUE(AllFinite(cloud));
    // "Moderate": cheap enough for unit tests of every downstream stage.
    EXPECT_GT(cloud.size(), 10'000u);
    EXPECT_LT(cloud.size(), 300'000u);
  }
}

TEST(ScenesTest, InvalidSpacingGivesEmptyCloud) {
  for (const double spacing : {0.0, -0.1, 0.001, std::nan("")}) {
    EXPECT_TRUE(GenerateStairsRampRoom(1, spacing).empty()) << spacing;
    EXPECT_TRUE(GenerateTwoLevelRamp(1, spacing).empty()) << spacing;
    EXPECT_TRUE(GenerateUnevenTerrain(1, spacing).empty()) << spacing;
  }
}

TEST(ScenesTest, FinerSpacingGivesMorePoints) {
  EXPECT_GT(GenerateStairsRampRoom(1, 0.05).size(), 3 * GenerateStairsRampRoom(1, 0.1).size());
  EXPECT_GT(GenerateTwoLevelRamp(1, 0.1).size(), 3 * GenerateTwoLevelRamp(1, 0.2).size());
}

// ---------------------------------------------------------------------------------------------
// Stairs, ramp and shelf room.

TEST(StairsRampRoomTest, LayoutIsConsistent) {
  const StairsRampLayout l = GetStairsRampLayout();
  // Stairs and ramp both reach the landing, from its front edge.
  EXPECT_NEAR(l.stair_risers * l.riser_m, l.landing_z_m, 1e-12);
  EXPECT_NEAR(l.riser_m, 0.15, 1e-12);
  EXPECT_NEAR(l.tread_m, 0.25, 1e-12);
  EXPECT_NEAR(l.stairs_y_max_m - l.stairs_y_min_m, (l.stair_risers - 1) * l.tread_m, 1e-12);
  EXPECT_NEAR(std::tan(l.ramp_slope_rad) * (l.ramp_y_max_m - l.ramp_y_min_m), l.landing_z_m, 1e-12);
  EXPECT_NEAR(l.ramp_slope_rad, 10.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(l.stairs_y_max_m, l.landing_y_min_m);
  EXPECT_DOUBLE_EQ(l.ramp_y_max_m, l.landing_y_min_m);
  // Side by side, at least 1 m apart in x.
  const double gap = std::max(l.stairs_x_min_m - l.ramp_x_max_m, l.ramp_x_min_m - l.stairs_x_max_m);
  EXPECT_GE(gap, 1.0);
  // Everything inside the room, in front of the landing.
  EXPECT_GT(l.ramp_y_min_m, 0.5);
  EXPECT_GT(l.ramp_x_min_m, 0.5);
  EXPECT_LT(l.stairs_x_max_m, l.room_x_max_m - 0.5);
  // The shelf stands over open floor, clear of walls, stairs and ramp by >= 0.5 m.
  const auto clearance_to = [&l](double x0, double x1, double y0, double y1) {
    const double dx = std::max({x0 - l.shelf_x_max_m, l.shelf_x_min_m - x1, 0.0});
    const double dy = std::max({y0 - l.shelf_y_max_m, l.shelf_y_min_m - y1, 0.0});
    return std::hypot(dx, dy);
  };
  EXPECT_GE(clearance_to(l.stairs_x_min_m, l.stairs_x_max_m, l.stairs_y_min_m, l.stairs_y_max_m),
            0.5);
  EXPECT_GE(clearance_to(l.ramp_x_min_m, l.ramp_x_max_m, l.ramp_y_min_m, l.ramp_y_max_m), 0.5);
  EXPECT_GE(l.shelf_x_min_m, 0.5);
  EXPECT_GE(l.shelf_y_min_m, 0.5);
  EXPECT_LE(l.shelf_x_max_m, l.room_x_max_m - 0.5);
  EXPECT_LE(l.shelf_y_max_m, l.landing_y_min_m - 0.5);
  EXPECT_NEAR(l.shelf_underside_z_m, 0.25, 1e-12);
  EXPECT_GT(l.shelf_top_z_m, l.shelf_underside_z_m);
}

class StairsRampRoomCloudTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { cloud_ = new PointCloud(GenerateStairsRampRoom(11)); }
  static void TearDownTestSuite() {
    delete cloud_;
    cloud_ = nullptr;
  }
  static const PointCloud& cloud() { return *cloud_; }

  const StairsRampLayout l_ = GetStairsRampLayout();
  // A point this far inside a face's outline cannot be a jittered point of a neighbouring face.
  const double margin_ = 0.03;
  const double tol_z_ = kMaxJitterZM + kFloatSlackM;

 private:
  static PointCloud* cloud_;
};
PointCloud* StairsRampRoomCloudTest::cloud_ = nullptr;

TEST_F(StairsRampRoomCloudTest, StaysWithinRoomBounds) {
  EXPECT_LT(cloud().size(), 100'000u);
  ExpectInBox(cloud(), {0, 0, 0}, {l_.room_x_max_m, l_.room_y_max_m, l_.wall_height_m},
              kRoomSpacingM);
}

TEST_F(StairsRampRoomCloudTest, LandingIsAtLandingHeight) {
  std::size_t n = 0;
  for (const Eigen::Vector3f& p : cloud()) {
    if (InRange(p.x(), margin_, l_.room_x_max_m - margin_) &&
        InRange(p.y(), l_.landing_y_min_m + margin_, l_.room_y_max_m - margin_)) {
      ASSERT_NEAR(p.z(), l_.landing_z_m, tol_z_) << "over the landing: " << p.transpose();
      ++n;
    }
  }
  // Most of the landing's lattice is there.
  const double area =
      (l_.room_x_max_m - 2 * margin_) * (l_.room_y_max_m - l_.landing_y_min_m - 2 * margin_);
  EXPECT_GT(n, 0.8 * area / (kRoomSpacingM * kRoomSpacingM));
}

TEST_F(StairsRampRoomCloudTest, RampPointsLieOnTheTenDegreePlane) {
  const double tan_slope = std::tan(l_.ramp_slope_rad);
  // Jitter in y moves a point along the slope by at most jitter·tan.
  const double tol = tol_z_ + MaxJitterXy(kRoomSpacingM) * tan_slope;
  std::size_t n = 0;
  for (const Eigen::Vector3f& p : cloud()) {
    if (InRange(p.x(), l_.ramp_x_min_m + margin_, l_.ramp_x_max_m - margin_) &&
        InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_)) {
      ASSERT_NEAR(p.z(), (p.y() - l_.ramp_y_min_m) * tan_slope, tol) << p.transpose();
      ++n;
    }
  }
  const double area = (l_.ramp_x_max_m - l_.ramp_x_min_m) * (l_.ramp_y_max_m - l_.ramp_y_min_m);
  EXPECT_GT(n, 0.7 * area / (kRoomSpacingM * kRoomSpacingM));
}

TEST_F(StairsRampRoomCloudTest, RampSidesAreSampledLikeASolidWedge) {
  const double tan_slope = std::tan(l_.ramp_slope_rad);
  for (const double x : {l_.ramp_x_min_m, l_.ramp_x_max_m}) {
    const std::size_t n = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
      return std::abs(p.x() - x) < 0.01 &&
             InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_) && p.z() > 0.02 &&
             p.z() < (p.y() - l_.ramp_y_min_m) * tan_slope - 0.02;
    });
    EXPECT_GT(n, 100u) << "ramp side at x = " << x;
  }
}

TEST_F(StairsRampRoomCloudTest, TreadsAndRisersAreSampled) {
  for (int k = 0; k < l_.stair_risers; ++k) {
    SCOPED_TRACE("step " + std::to_string(k));
    const double y = l_.stairs_y_min_m + k * l_.tread_m;
    const auto in_stairs_x = [&](const Eigen::Vector3f& p) {
      return InRange(p.x(), l_.stairs_x_min_m + margin_, l_.stairs_x_max_m - margin_);
    };
    const std::size_t riser = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
      return in_stairs_x(p) && std::abs(p.y() - y) < 0.01 &&
             InRange(p.z(), k * l_.riser_m + 0.02, (k + 1) * l_.riser_m - 0.02);
    });
    EXPECT_GT(riser, 0u);
    if (k + 1 == l_.stair_risers) continue;  // The top riser's tread is the landing.
    std::size_t tread = 0;
    for (const Eigen::Vector3f& p : cloud()) {
      if (in_stairs_x(p) && InRange(p.y(), y + margin_, y + l_.tread_m - margin_)) {
        ASSERT_NEAR(p.z(), (k + 1) * l_.riser_m, tol_z_) << p.transpose();
        ++tread;
      }
    }
    EXPECT_GT(tread, 0u);
  }
}

TEST_F(StairsRampRoomCloudTest, NothingIsSampledInsideTheSolids) {
  const double tan_slope = std::tan(l_.ramp_slope_rad);
  const std::size_t inside = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
    const bool in_ramp = InRange(p.x(), l_.ramp_x_min_m + margin_, l_.ramp_x_max_m - margin_) &&
                         InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_) &&
                         p.z() < (p.y() - l_.ramp_y_min_m) * tan_slope - 0.02;
    const bool in_stairs =
        InRange(p.x(), l_.stairs_x_min_m + margin_, l_.stairs_x_max_m - margin_) &&
        InRange(p.y(), l_.stairs_y_min_m + margin_, l_.stairs_y_max_m - margin_) &&
        p.z() < l_.riser_m - 0.02;
    const bool in_landing = InRange(p.y(), l_.landing_y_min_m + margin_, l_.room_y_max_m + 1.0) &&
                            p.z() < l_.landing_z_m - 0.02;
    return in_ramp || in_stairs || in_landing;
  });
  EXPECT_EQ(inside, 0u);
}

TEST_F(StairsRampRoomCloudTest, ShelfOverhangsSampledFloor) {
  const auto under_shelf = [&](const Eigen::Vector3f& p, double z) {
    return InRange(p.x(), l_.shelf_x_min_m + 0.1, l_.shelf_x_max_m - 0.1) &&
           InRange(p.y(), l_.shelf_y_min_m + 0.1, l_.shelf_y_max_m - 0.1) &&
           std::abs(p.z() - z) <= tol_z_;
  };
  const double area =
      (l_.shelf_x_max_m - l_.shelf_x_min_m - 0.2) * (l_.shelf_y_max_m - l_.shelf_y_min_m - 0.2);
  const double expected = area / (kRoomSpacingM * kRoomSpacingM);
  for (const double z : {0.0, l_.shelf_underside_z_m, l_.shelf_top_z_m}) {
    EXPECT_GT(CountIf(cloud(), [&](const Eigen::Vector3f& p) { return under_shelf(p, z); }),
              0.8 * expected)
        << "at z = " << z;
  }
}

// ---------------------------------------------------------------------------------------------
// Two-level hall with a ramp.

TEST(TwoLevelRampTest, LayoutIsConsistent) {
  const TwoLevelRampLayout l = GetTwoLevelRampLayout();
  EXPECT_NEAR(l.deck_z_m, 3.0, 1e-12);
  EXPECT_NEAR(l.deck_underside_z_m, 2.8, 1e-12);
  EXPECT_NEAR(l.ramp_slope_rad, 12.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(l.ramp_uphill_dir.norm(), 1.0, 1e-12);
  // The ramp climbs from the floor exactly to the deck, arriving at the deck's edge.
  const double run = (l.ramp_x_max_m - l.ramp_x_min_m) * l.ramp_uphill_dir.x() +
                     (l.ramp_y_max_m - l.ramp_y_min_m) * l.ramp_uphill_dir.y();
  EXPECT_NEAR(std::tan(l.ramp_slope_rad) * run, l.deck_z_m - l.floor_z_m, 1e-9);
  EXPECT_TRUE(l.IsOverDeck(l.ramp_x_max_m, 0.5 * (l.ramp_y_min_m + l.ramp_y_max_m)));
  EXPECT_FALSE(l.IsOverDeck(l.ramp_x_max_m - 0.1, 0.5 * (l.ramp_y_min_m + l.ramp_y_max_m)));
  EXPECT_GT(l.ramp_x_min_m, 0.5);
  EXPECT_NEAR(l.ramp_y_max_m - l.ramp_y_min_m, 2.5, 1e-12);
  // The deck covers roughly half the hall.
  const double deck_area = l.room_x_max_m * (l.room_y_max_m - l.deck_y_min_m) +
                           (l.room_x_max_m - l.deck_tongue_x_min_m) * l.deck_y_min_m;
  const double fraction = deck_area / (l.room_x_max_m * l.room_y_max_m);
  EXPECT_GT(fraction, 0.4);
  EXPECT_LT(fraction, 0.6);
  // Pillars stand under the deck; examples are where they say.
  EXPECT_GE(l.pillar_centers_m.size(), 4u);
  EXPECT_LE(l.pillar_centers_m.size(), 6u);
  for (const Eigen::Vector2d& c : l.pillar_centers_m) {
    EXPECT_TRUE(l.IsOverDeck(c.x(), c.y()));
  }
  EXPECT_FALSE(l.IsOverDeck(l.start_example_m.x(), l.start_example_m.y()));
  EXPECT_DOUBLE_EQ(l.start_example_m.z(), l.floor_z_m);
  EXPECT_TRUE(l.IsOverDeck(l.goal_example_m.x(), l.goal_example_m.y()));
  EXPECT_DOUBLE_EQ(l.goal_example_m.z(), l.deck_z_m);
}

class TwoLevelRampCloudTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { cloud_ = new PointCloud(GenerateTwoLevelRamp(5)); }
  static void TearDownTestSuite() {
    delete cloud_;
    cloud_ = nullptr;
  }
  static const PointCloud& cloud() { return *cloud_; }

  const TwoLevelRampLayout l_ = GetTwoLevelRampLayout();
  const double margin_ = 0.05;
  const double tol_z_ = kMaxJitterZM + kFloatSlackM;

 private:
  static PointCloud* cloud_;
};
PointCloud* TwoLevelRampCloudTest::cloud_ = nullptr;

TEST_F(TwoLevelRampCloudTest, StaysWithinHallBounds) {
  ExpectInBox(cloud(), {0, 0, l_.floor_z_m}, {l_.room_x_max_m, l_.room_y_max_m, l_.wall_height_m},
              kHallSpacingM);
}

TEST_F(TwoLevelRampCloudTest, StartIsOpenFloorAndGoalIsDeck) {
  const auto near_xy = [](const Eigen::Vector3f& p, const Eigen::Vector3d& q) {
    return std::hypot(p.x() - q.x(), p.y() - q.y()) < 0.5;
  };
  std::size_t at_start = 0;
  std::size_t deck_top = 0, deck_underside = 0, floor_below = 0;
  for (const Eigen::Vector3f& p : cloud()) {
    if (near_xy(p, l_.start_example_m)) {
      // Nothing above the start: all points there are floor.
      ASSERT_NEAR(p.z(), l_.start_example_m.z(), tol_z_) << p.transpose();
      ++at_start;
    }
    if (near_xy(p, l_.goal_example_m)) {
      deck_top += std::abs(p.z() - l_.deck_z_m) <= tol_z_;
      deck_underside += std::abs(p.z() - l_.deck_underside_z_m) <= tol_z_;
      floor_below += std::abs(p.z() - l_.floor_z_m) <= tol_z_;
      ASSERT_LE(p.z(), l_.deck_z_m + tol_z_) << "something above the goal: " << p.transpose();
    }
  }
  EXPECT_GT(at_start, 50u);
  EXPECT_GT(deck_top, 50u);
  EXPECT_GT(deck_underside, 50u);
  EXPECT_GT(floor_below, 50u);
}

TEST_F(TwoLevelRampCloudTest, RampPointsLieOnTheTwelveDegreePlane) {
  const double tan_slope = std::tan(l_.ramp_slope_rad);
  const double tol = tol_z_ + MaxJitterXy(kHallSpacingM) * tan_slope;
  std::size_t n = 0;
  for (const Eigen::Vector3f& p : cloud()) {
    if (InRange(p.x(), l_.ramp_x_min_m + margin_, l_.ramp_x_max_m - margin_) &&
        InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_)) {
      ASSERT_NEAR(p.z(), l_.floor_z_m + (p.x() - l_.ramp_x_min_m) * tan_slope, tol)
          << p.transpose();
      ++n;
    }
  }
  const double area = (l_.ramp_x_max_m - l_.ramp_x_min_m) * (l_.ramp_y_max_m - l_.ramp_y_min_m);
  EXPECT_GT(n, 0.7 * area / (kHallSpacingM * kHallSpacingM));
}

TEST_F(TwoLevelRampCloudTest, RailingRunsAlongOpenEdgesExceptWhereTheRampArrives) {
  const auto railing_near = [&](const Eigen::Vector3f& p) {
    return InRange(p.z(), l_.deck_z_m + 0.1, l_.deck_z_m + l_.railing_height_m) &&
           std::abs(p.x() - l_.deck_tongue_x_min_m) < 0.02;
  };
  EXPECT_EQ(CountIf(cloud(),
                    [&](const Eigen::Vector3f& p) {
                      return railing_near(p) &&
                             InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_);
                    }),
            0u);
  EXPECT_GT(CountIf(cloud(),
                    [&](const Eigen::Vector3f& p) {
                      return railing_near(p) &&
                             InRange(p.y(), l_.ramp_y_max_m + margin_, l_.deck_y_min_m - margin_);
                    }),
            100u);
  EXPECT_GT(CountIf(cloud(),
                    [&](const Eigen::Vector3f& p) {
                      return std::abs(p.y() - l_.deck_y_min_m) < 0.02 &&
                             InRange(p.x(), margin_, l_.deck_tongue_x_min_m - margin_) &&
                             InRange(p.z(), l_.deck_z_m + 0.1, l_.deck_z_m + l_.railing_height_m);
                    }),
            1000u);
}

TEST_F(TwoLevelRampCloudTest, PillarsAreSampledAndHollowInside) {
  for (const Eigen::Vector2d& c : l_.pillar_centers_m) {
    SCOPED_TRACE("pillar at " + std::to_string(c.x()) + ", " + std::to_string(c.y()));
    const auto radial = [&](const Eigen::Vector3f& p) {
      return std::hypot(p.x() - c.x(), p.y() - c.y());
    };
    EXPECT_GT(CountIf(cloud(),
                      [&](const Eigen::Vector3f& p) {
                        return std::abs(radial(p) - l_.pillar_radius_m) < 0.02 &&
                               InRange(p.z(), 0.5, 2.5);
                      }),
              100u);
    // No floor or underside points inside the pillar.
    EXPECT_EQ(CountIf(cloud(),
                      [&](const Eigen::Vector3f& p) {
                        return radial(p) < l_.pillar_radius_m - 0.05 &&
                               p.z() < l_.deck_underside_z_m + 0.05;
                      }),
              0u);
  }
}

TEST_F(TwoLevelRampCloudTest, NoFloorUnderTheRamp) {
  const double tan_slope = std::tan(l_.ramp_slope_rad);
  EXPECT_EQ(CountIf(cloud(),
                    [&](const Eigen::Vector3f& p) {
                      return InRange(p.x(), l_.ramp_x_min_m + 0.2, l_.ramp_x_max_m - margin_) &&
                             InRange(p.y(), l_.ramp_y_min_m + margin_, l_.ramp_y_max_m - margin_) &&
                             p.z() < (p.x() - l_.ramp_x_min_m) * tan_slope - 0.02;
                    }),
            0u);
}

// ---------------------------------------------------------------------------------------------
// Uneven terrain.

double SlopeDeg(const UnevenTerrainLayout& l, double x, double y) {
  return std::atan(l.GradientAt(x, y).norm()) * 180.0 / std::numbers::pi;
}

TEST(UnevenTerrainTest, LayoutMeetsTheDescription) {
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const UnevenTerrainLayout l = GetUnevenTerrainLayout(seed);
    EXPECT_NEAR(l.size_m, 30.0, 1e-12);
    EXPECT_GE(l.trees.size(), 15u);
    EXPECT_LE(l.trees.size(), 25u);
    EXPECT_GE(l.rocks.size(), 10u);
    EXPECT_LE(l.rocks.size(), 15u);
    for (const auto& t : l.trees) {
      EXPECT_TRUE(InRange(t.trunk_radius_m, 0.15, 0.3));
      EXPECT_TRUE(InRange(t.crown_radius_m, 1.0, 2.0));
      EXPECT_TRUE(InRange(t.crown_center_z_m - t.ground_z_m, 3.0, 5.0));
      EXPECT_GT(t.crown_center_z_m - t.crown_radius_m - t.ground_z_m, 2.0);
      EXPECT_NEAR(t.ground_z_m, l.HeightAt(t.x_m, t.y_m), 1e-12);
      EXPECT_TRUE(InRange(t.x_m - t.crown_radius_m, 0.0, l.size_m) &&
                  InRange(t.x_m + t.crown_radius_m, 0.0, l.size_m) &&
                  InRange(t.y_m - t.crown_radius_m, 0.0, l.size_m) &&
                  InRange(t.y_m + t.crown_radius_m, 0.0, l.size_m));
    }
    for (const auto& r : l.rocks) {
      EXPECT_TRUE(InRange(r.radius_xy_m, 0.3, 0.8));
      EXPECT_GT(r.radius_z_m, 0.0);
      EXPECT_LT(r.center_z_m, l.HeightAt(r.x_m, r.y_m));  // Partly buried.
    }
    // Slopes range from gentle to beyond 30°.
    std::size_t gentle = 0, total = 0;
    double max_slope_deg = 0.0;
    for (double x = 0.0; x <= l.size_m; x += 0.25) {
      for (double y = 0.0; y <= l.size_m; y += 0.25) {
        const double s = SlopeDeg(l, x, y);
        max_slope_deg = std::max(max_slope_deg, s);
        gentle += s < 10.0;
        ++total;
      }
    }
    EXPECT_GT(max_slope_deg, 30.0);
    EXPECT_GT(static_cast<double>(gentle) / total, 0.2);
  }
}

TEST(UnevenTerrainTest, GradientMatchesFiniteDifferences) {
  const UnevenTerrainLayout l = GetUnevenTerrainLayout(4);
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> coord(0.0, l.size_m);
  constexpr double kH = 1e-5;
  for (int i = 0; i < 200; ++i) {
    const double x = coord(rng), y = coord(rng);
    const Eigen::Vector2d g = l.GradientAt(x, y);
    EXPECT_NEAR(g.x(), (l.HeightAt(x + kH, y) - l.HeightAt(x - kH, y)) / (2 * kH), 1e-6);
    EXPECT_NEAR(g.y(), (l.HeightAt(x, y + kH) - l.HeightAt(x, y - kH)) / (2 * kH), 1e-6);
  }
}

TEST(UnevenTerrainTest, SeedChangesTheLayout) {
  const UnevenTerrainLayout a = GetUnevenTerrainLayout(1);
  const UnevenTerrainLayout b = GetUnevenTerrainLayout(2);
  EXPECT_NE(a.HeightAt(10.0, 10.0), b.HeightAt(10.0, 10.0));
  EXPECT_NE(a.trees.front().x_m, b.trees.front().x_m);
}

TEST(UnevenTerrainTest, LayoutDoesNotDependOnSpacing) {
  // Points of the same scene at two spacings lie on the same terrain.
  const UnevenTerrainLayout l = GetUnevenTerrainLayout(8);
  const PointCloud coarse = GenerateUnevenTerrain(8, 0.3);
  const std::size_t on_ground = CountIf(coarse, [&](const Eigen::Vector3f& p) {
    return std::abs(p.z() - l.HeightAt(p.x(), p.y())) < 0.05;
  });
  EXPECT_GT(on_ground, coarse.size() / 2);
}

class UnevenTerrainCloudTest : public ::testing::Test {
 protected:
  static constexpr std::uint32_t kSeed = 21;
  static void SetUpTestSuite() { cloud_ = new PointCloud(GenerateUnevenTerrain(kSeed)); }
  static void TearDownTestSuite() {
    delete cloud_;
    cloud_ = nullptr;
  }
  static const PointCloud& cloud() { return *cloud_; }

  const UnevenTerrainLayout l_ = GetUnevenTerrainLayout(kSeed);

  // How far a jittered terrain point can be from HeightAt at its jittered (x, y).
  double GroundTolerance(double x, double y) const {
    return kMaxJitterZM +
           std::sqrt(2.0) * MaxJitterXy(kTerrainSpacingM) * l_.GradientAt(x, y).norm() + 1e-3;
  }

 private:
  static PointCloud* cloud_;
};
PointCloud* UnevenTerrainCloudTest::cloud_ = nullptr;

TEST_F(UnevenTerrainCloudTest, StaysWithinBoundsAndAboveGround) {
  double top = -1e9;
  for (const auto& t : l_.trees) top = std::max(top, t.crown_center_z_m + t.crown_radius_m);
  ExpectInBox(cloud(), {0.0, 0.0, -10.0}, {l_.size_m, l_.size_m, top}, kTerrainSpacingM);
  for (const Eigen::Vector3f& p : cloud()) {
    ASSERT_GE(p.z(), l_.HeightAt(p.x(), p.y()) - GroundTolerance(p.x(), p.y()))
        << "below ground: " << p.transpose();
  }
}

TEST_F(UnevenTerrainCloudTest, MostPointsAreGroundAndTreesAndRocksAreSampled) {
  const std::size_t ground = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
    return std::abs(p.z() - l_.HeightAt(p.x(), p.y())) <= GroundTolerance(p.x(), p.y());
  });
  EXPECT_GT(ground, cloud().size() / 2);
  for (const auto& t : l_.trees) {
    const double crown_top = t.crown_center_z_m + t.crown_radius_m;
    const std::size_t near_top = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
      return std::hypot(p.x() - t.x_m, p.y() - t.y_m) < 0.3 && std::abs(p.z() - crown_top) < 0.05;
    });
    EXPECT_GT(near_top, 0u) << "crown of tree at " << t.x_m << ", " << t.y_m;
    // Between the ground and the crown bottom, only the trunk: nothing 0.1 m beyond it.
    const std::size_t under_crown = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
      const double r = std::hypot(p.x() - t.x_m, p.y() - t.y_m);
      return r > t.trunk_radius_m + 0.1 && r < 0.5 * t.crown_radius_m &&
             InRange(p.z(), t.ground_z_m + 1.5, t.crown_center_z_m - t.crown_radius_m - 0.1);
    });
    EXPECT_EQ(under_crown, 0u) << "tree at " << t.x_m << ", " << t.y_m;
  }
  for (const auto& r : l_.rocks) {
    const double rock_top = r.center_z_m + r.radius_z_m;
    const std::size_t near_top = CountIf(cloud(), [&](const Eigen::Vector3f& p) {
      return std::hypot(p.x() - r.x_m, p.y() - r.y_m) < 0.2 && std::abs(p.z() - rock_top) < 0.05;
    });
    EXPECT_GT(near_top, 0u) << "rock at " << r.x_m << ", " << r.y_m;
  }
}

// ---------------------------------------------------------------------------------------------
// By name.

TEST(GenerateSceneTest, EveryNameGivesItsSceneAtDefaultSpacing) {
  const std::vector<std::string> names = SceneNames();
  // These three, the paper's scenes (paper_scenes_test.cpp) and outdoor_site
  // (outdoor_site_test.cpp), each once.
  ASSERT_EQ(names.size(), 9u);
  for (const std::string& name : names) {
    EXPECT_EQ(std::count(names.begin(), names.end(), name), 1) << name;
  }
  for (const SceneCase& scene : AllScenes()) {
    SCOPED_TRACE(scene.name);
    EXPECT_NE(std::find(names.begin(), names.end(), scene.name), names.end());
    const Expected<PointCloud> cloud = GenerateScene(scene.name, 4);
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    EXPECT_TRUE(*cloud == scene.generate(4));
  }
}

TEST(GenerateSceneTest, OptionsResolveToTheScenesDefaults) {
  Expected<SceneOptions> options = ResolveSceneOptions("outdoor_site", {});
  ASSERT_TRUE(options.ok()) << options.error().message;
  EXPECT_EQ(options->size_m, 100.0);
  EXPECT_EQ(options->spacing_m, 0.1);
  options = ResolveSceneOptions("outdoor_site", {.size_m = 400.0, .spacing_m = 0.2});
  ASSERT_TRUE(options.ok()) << options.error().message;
  EXPECT_EQ(options->size_m, 400.0);
  EXPECT_EQ(options->spacing_m, 0.2);
  options = ResolveSceneOptions("stairs_ramp_room", {});
  ASSERT_TRUE(options.ok()) << options.error().message;
  EXPECT_FALSE(options->size_m.has_value());  // No size parameter.
  EXPECT_EQ(options->spacing_m, 0.05);
}

TEST(GenerateSceneTest, OptionsOutOfPlaceOrRangeAreInvalidInputNamingThem) {
  // A size for a scene that has none names the scenes that take one.
  Expected<PointCloud> cloud = GenerateScene("two_level_ramp", 1, {.size_m = 50.0});
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(cloud.error().message, HasSubstr("two_level_ramp has no size parameter"));
  EXPECT_THAT(cloud.error().message, HasSubstr("outdoor_site"));
  for (const double size : {39.9, 1000.1, std::nan("")}) {
    cloud = GenerateScene("outdoor_site", 1, {.size_m = size});
    ASSERT_FALSE(cloud.ok()) << size;
    EXPECT_EQ(cloud.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(cloud.error().message, HasSubstr("size_m"));
    EXPECT_THAT(cloud.error().message, HasSubstr("[40, 1000] m"));
  }
  cloud = GenerateScene("outdoor_site", 1, {.spacing_m = 0.005});
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(cloud.error().message, HasSubstr("spacing_m = 0.005"));
  EXPECT_FALSE(EstimateScenePoints("two_level_ramp", 1, {.size_m = 50.0}).ok());
}

TEST(GenerateSceneTest, EstimatesFollowTheCounts) {
  for (const std::string& name : SceneNames()) {
    for (const std::uint32_t seed : {1u, 4u}) {
      SCOPED_TRACE(name + ", seed " + std::to_string(seed));
      const double points = static_cast<double>(GenerateScene(name, seed)->size());
      const double estimate = EstimateScenePoints(name, seed).value();
      EXPECT_NEAR(estimate / points, 1.0, 0.12);
      // A quarter of the points at twice the spacing.
      const double spacing = ResolveSceneOptions(name, {})->spacing_m.value();
      const double coarse = EstimateScenePoints(name, seed, {.spacing_m = 2 * spacing}).value();
      EXPECT_NEAR(coarse / estimate, 0.25, 0.02);
    }
  }
}

TEST(GenerateSceneTest, RefusesBeforeGeneratingWhatWouldPassMaxPoints) {
  // Far beyond: 1e10 points; generating them would not end in this test's lifetime.
  Expected<PointCloud> cloud =
      GenerateScene("outdoor_site", 1, {.size_m = 1000.0, .spacing_m = 0.01});
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(cloud.error().message, HasSubstr("size_m = 1000, spacing_m = 0.01"));
  EXPECT_THAT(cloud.error().message, HasSubstr("above the limit of 50000000"));
  // The spacing the message names fits.
  cloud = GenerateScene("two_level_ramp", 1, {}, 10'000);
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(cloud.error().message, HasSubstr("use spacing_m >= 0.3"));
  EXPECT_TRUE(GenerateScene("two_level_ramp", 1, {.spacing_m = 0.3}, 10'000).ok());
}

TEST(GenerateSceneTest, UnknownNameIsInvalidInputNamingKnownScenes) {
  const Expected<PointCloud> cloud = GenerateScene("no_such_scene", 1);
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(cloud.error().message, HasSubstr("no_such_scene"));
  for (const std::string& name : SceneNames()) {
    EXPECT_THAT(cloud.error().message, HasSubstr(name));
  }
}

}  // namespace
}  // namespace strata
