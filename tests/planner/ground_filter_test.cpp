#include "strata/assessment/ground_filter.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "strata/scenes/basic_scenes.hpp"

namespace strata {
namespace {

// The rule of docs/design.md §3 evaluated literally: every pair, the elevation angle by atan2.
std::vector<std::uint8_t> NaiveValidGround(const PointCloud& cloud,
                                           const GroundFilterConfig& config) {
  std::vector<std::uint8_t> valid(cloud.size(), 1);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (std::size_t j = 0; j < cloud.size(); ++j) {
      const Eigen::Vector3d p = cloud[i].cast<double>();
      const Eigen::Vector3d q = cloud[j].cast<double>();
      if (i == j || (q - p).norm() > config.radius_m) continue;
      const double rise = q.z() - p.z() - config.height_tolerance_m;
      if (rise <= 0) continue;
      const double elevation = std::atan2(rise, (q - p).head<2>().norm());
      if (elevation >= config.max_tilt_rad) {
        valid[i] = 0;
        break;
      }
    }
  }
  return valid;
}

PointCloud RandomCloud(std::uint32_t seed, int count, double extent_m, double height_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> xy(0.0f, static_cast<float>(extent_m));
  std::uniform_real_distribution<float> z(0.0f, static_cast<float>(height_m));
  PointCloud cloud(count);
  for (auto& p : cloud) p = {xy(rng), xy(rng), z(rng)};
  return cloud;
}

TEST(GroundFilter, MatchesNaiveRuleOnRandomClouds) {
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    GroundFilterConfig config;
    config.radius_m = 0.2 + 0.05 * seed;
    config.max_tilt_rad = (10.0 + 8.0 * seed) * std::numbers::pi / 180.0;
    config.height_tolerance_m = seed % 2 == 0 ? 0.0 : 0.02;
    // Flat-ish layers give a mix of kept and rejected points.
    const PointCloud cloud = RandomCloud(seed, 1500, 3.0, seed % 3 == 0 ? 1.0 : 0.15);
    const auto fast = FilterValidGround(cloud, config, /*num_threads=*/2);
    const auto naive = NaiveValidGround(cloud, config);
    ASSERT_EQ(fast.size(), naive.size());
    int kept = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      EXPECT_EQ(fast[i], naive[i]) << "seed " << seed << " point " << i;
      kept += fast[i];
    }
    // The case is only informative when both outcomes occur.
    EXPECT_GT(kept, 0) << "seed " << seed;
    EXPECT_LT(kept, static_cast<int>(cloud.size())) << "seed " << seed;
  }
}

TEST(GroundFilter, IndependentOfThreadCount) {
  const PointCloud cloud = RandomCloud(7, 3000, 4.0, 0.3);
  const GroundFilterConfig config;
  EXPECT_EQ(FilterValidGround(cloud, config, 1), FilterValidGround(cloud, config, 2));
}

TEST(GroundFilter, EmptyCloud) { EXPECT_TRUE(FilterValidGround({}, GroundFilterConfig{}).empty()); }

TEST(GroundFilter, PointDirectlyBelowAnotherIsRejected) {
  const PointCloud cloud = {{0, 0, 0}, {0, 0, 0.1f}, {1, 1, 0}};
  GroundFilterConfig config;
  config.height_tolerance_m = 0;
  const auto valid = FilterValidGround(cloud, config);
  EXPECT_EQ(valid, (std::vector<std::uint8_t>{0, 1, 1}));
}

class StairsRampScene : public ::testing::Test {
 protected:
  void SetUp() override {
    cloud_ = GenerateStairsRampRoom(/*seed=*/3);
    config_.radius_m = 0.3;
    config_.max_tilt_rad = 20.0 * std::numbers::pi / 180.0;
    valid_ = FilterValidGround(cloud_, config_);
  }

  // Fraction of points inside the xy box (shrunk by `margin`) and z range that are valid.
  double ValidFraction(double x0, double x1, double y0, double y1, double z0, double z1,
                       double margin, int* count) const {
    int inside = 0;
    int kept = 0;
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      const auto& p = cloud_[i];
      if (p.x() < x0 + margin || p.x() > x1 - margin || p.y() < y0 + margin ||
          p.y() > y1 - margin || p.z() < z0 || p.z() > z1) {
        continue;
      }
      ++inside;
      kept += valid_[i];
    }
    *count = inside;
    return inside > 0 ? static_cast<double>(kept) / inside : 0.0;
  }

  PointCloud cloud_;
  GroundFilterConfig config_;
  std::vector<std::uint8_t> valid_;
  StairsRampLayout layout_ = GetStairsRampLayout();
};

TEST_F(StairsRampScene, StairTreadsAreRejected) {
  int count = 0;
  // Tread and riser points strictly between the floor and the landing.
  const double fraction =
      ValidFraction(layout_.stairs_x_min_m, layout_.stairs_x_max_m, layout_.stairs_y_min_m,
                    layout_.stairs_y_max_m, 0.05, layout_.landing_z_m - 0.05, 0.0, &count);
  ASSERT_GT(count, 100);
  EXPECT_EQ(fraction, 0.0);
}

TEST_F(StairsRampScene, GentleRampIsKept) {
  ASSERT_LT(layout_.ramp_slope_rad, config_.max_tilt_rad);
  int count = 0;
  // The ramp's surface, away from its sides and ends by more than the filter radius.
  const double fraction = ValidFraction(
      layout_.ramp_x_min_m, layout_.ramp_x_max_m, layout_.ramp_y_min_m, layout_.ramp_y_max_m, 0.05,
      layout_.landing_z_m - 0.05, config_.radius_m + 0.05, &count);
  ASSERT_GT(count, 100);
  EXPECT_EQ(fraction, 1.0);
}

TEST_F(StairsRampScene, FloorUnderTheShelfIsRejectedAndOpenFloorKept) {
  int count = 0;
  const double under =
      ValidFraction(layout_.shelf_x_min_m, layout_.shelf_x_max_m, layout_.shelf_y_min_m,
                    layout_.shelf_y_max_m, -0.02, 0.02, 0.05, &count);
  ASSERT_GT(count, 20);
  EXPECT_EQ(under, 0.0);

  // Open floor between the shelf and the stairs/ramp side of the room is ground.
  const double open =
      ValidFraction(layout_.shelf_x_min_m, layout_.shelf_x_max_m, layout_.shelf_y_max_m + 0.5,
                    layout_.shelf_y_max_m + 1.0, -0.02, 0.02, 0.0, &count);
  ASSERT_GT(count, 20);
  EXPECT_GT(open, 0.99);
}

TEST_F(StairsRampScene, SteepRampIsRejectedWhenThetaIsBelowItsSlope) {
  GroundFilterConfig strict = config_;
  strict.max_tilt_rad = 0.5 * layout_.ramp_slope_rad;
  valid_ = FilterValidGround(cloud_, strict);
  int count = 0;
  const double fraction = ValidFraction(
      layout_.ramp_x_min_m, layout_.ramp_x_max_m, layout_.ramp_y_min_m, layout_.ramp_y_max_m, 0.05,
      layout_.landing_z_m - 0.05, config_.radius_m + 0.05, &count);
  ASSERT_GT(count, 100);
  EXPECT_LT(fraction, 0.05);
}

}  // namespace
}  // namespace strata
