#include "strata/fleet/map_change.hpp"

#include <memory>
#include <optional>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/map_edit.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

// A flat floor 6 m × 3 m at z = 0, a point every 5 cm.
PointCloud Floor() {
  PointCloud cloud;
  for (int i = 0; i <= 120; ++i) {
    for (int j = 0; j <= 60; ++j) cloud.emplace_back(0.05f * i, 0.05f * j, 0.0f);
  }
  return cloud;
}

std::shared_ptr<const TerrainModel> Assessed(const PointCloud& cloud) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  config.num_threads = 1;
  return TerrainModel::Assess(cloud, config).value();
}

// Along y = 1.5 from x = 1 to x = 5 at 1 m/s, the reference point 0.3 m up, parked 10 s.
FleetMotion Crossing(std::int64_t start_ns) {
  FleetMotion motion;
  motion.start_ns = start_ns;
  TrajectoryPiece piece;
  piece.duration_s = 4;
  piece.coefficients = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, 3);
  piece.coefficients(0, 0) = 1;
  piece.coefficients(1, 0) = 1;
  piece.coefficients(0, 1) = 1.5;
  piece.coefficients(0, 2) = 0.3;
  motion.trajectory.pieces = {piece};
  motion.end_ns = AddSeconds(start_ns, 14);
  return motion;
}

constexpr std::int64_t kStart = 1'000'000'000'000;

TEST(FirstUnsafeOnMap, ASafeMotionStaysSafe) {
  const PlanningMap map(Assessed(Floor()));
  EXPECT_EQ(FirstUnsafeOnMap(map, Crossing(kStart), kStart), std::nullopt);
}

TEST(FirstUnsafeOnMap, APalletOnThePathIsFoundWhereTheRobotMeetsIt) {
  const PointCloud floor = Floor();
  const std::shared_ptr<const TerrainModel> base = Assessed(floor);
  // A pallet 0.4 m × 0.4 m, 0.8 m high, centred on the path at x = 3.
  const MapEdit pallet{
      MapEdit::Kind::kAddObstacle,
      BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(2.8, 1.3, 0.0), Eigen::Vector3d(3.2, 1.7, 0.8))),
      nullptr};
  const PlanningMap map(Assessed(ApplyEdits(floor, {&pallet, 1}, *base).value()));
  const std::optional<UnsafeMotion> unsafe = FirstUnsafeOnMap(map, Crossing(kStart), kStart);
  ASSERT_TRUE(unsafe.has_value());
  // At the pallet's face: its points stand at the centres of the columns from x = 2.85 on,
  // and the column there has the pallet's top for its ground.
  EXPECT_NEAR(unsafe->position_m.x(), 2.8, 0.1);
  EXPECT_NEAR(SecondsBetween(kStart, unsafe->time_ns), 1.8, 0.1);
  EXPECT_THAT(unsafe->reason, ::testing::AnyOf(HasSubstr("obstacle"), HasSubstr("ground is")));
  // Past the pallet, nothing is in the way any more.
  EXPECT_EQ(FirstUnsafeOnMap(map, Crossing(kStart), AddSeconds(kStart, 2.5)), std::nullopt);
}

TEST(FirstUnsafeOnMap, AHoleUnderThePathIsFound) {
  const PointCloud floor = Floor();
  const std::shared_ptr<const TerrainModel> base = Assessed(floor);
  const MapEdit hole{MapEdit::Kind::kRemovePoints,
                     BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(3.5, 1.0, -0.5),
                                                  Eigen::Vector3d(4.2, 2.0, 0.5))),
                     nullptr};
  const PlanningMap map(Assessed(ApplyEdits(floor, {&hole, 1}, *base).value()));
  const std::optional<UnsafeMotion> unsafe = FirstUnsafeOnMap(map, Crossing(kStart), kStart);
  ASSERT_TRUE(unsafe.has_value());
  EXPECT_GT(unsafe->position_m.x(), 3.3);
  EXPECT_LT(unsafe->position_m.x(), 3.7);
}

TEST(FirstUnsafeOnMap, AKeepOutZoneOverTheParkedEndIsFound) {
  const PlanningMap open(Assessed(Floor()));
  const std::shared_ptr<const PlanningMap> closed = open.WithKeepOut(
      {BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(5.2, 1.0, -1), Eigen::Vector3d(5.8, 2.0, 2)))});
  // The footprint (0.3 m) reaches 0.1 m into the zone at the end, x = 5, where it parks.
  const std::optional<UnsafeMotion> unsafe = FirstUnsafeOnMap(*closed, Crossing(kStart), kStart);
  ASSERT_TRUE(unsafe.has_value());
  EXPECT_THAT(unsafe->reason, HasSubstr("keep-out zone"));
  EXPECT_NEAR(unsafe->position_m.x(), 4.9, 0.1);
  // A motion whose lease has run out is no one's concern.
  EXPECT_EQ(FirstUnsafeOnMap(*closed, Crossing(kStart), AddSeconds(kStart, 15)), std::nullopt);
}

}  // namespace
}  // namespace strata
