// The request of a replan on the way: the followed trajectory's state at the robot's time
// becomes the start, and the trajectory the warm start.
#include "strata/client/replan.hpp"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "trajectory_builders.hpp"

namespace strata::client {
namespace {

using ::testing::HasSubstr;

// Two pieces of 2 s: x = t + t², y = 3 − t³ on the first, then z constant.
v1::PlanResponse Followed() {
  v1::PlanResponse response;
  *response.mutable_trajectory() = testing::MakeTrajectory(
      3, {{2.0, {{0, 1, 1, 0, 0, 0}, {3, 0, 0, -1, 0, 0}, {0.3, 0, 0, 0, 0, 0}}},
          {2.0, {{6, 5, 1, 0, 0, 0}, {-5, -12, -6, -1, 0, 0}, {0.3, 0, 0, 0, 0, 0}}}});
  return response;
}

v1::PlanRequest Original() {
  v1::PlanRequest request;
  request.set_map_id("demo");
  request.set_profile_name("differential");
  request.mutable_start()->mutable_position_m()->set_x(0);
  request.mutable_goal()->mutable_position_m()->set_x(12);
  request.mutable_options()->set_time_budget_s(1.5);
  return request;
}

TEST(MakeReplanRequest, StartsWhereTheFollowedTrajectoryIsAndCarriesIt) {
  const auto replan = MakeReplanRequest(Original(), Followed(), 1.0);
  ASSERT_TRUE(replan.ok()) << replan.error().message;
  // At t = 1 on the first piece: x = 2, x' = 3, x'' = 2; y = 2, y' = −3, y'' = −6.
  EXPECT_DOUBLE_EQ(replan->start().position_m().x(), 2);
  EXPECT_DOUBLE_EQ(replan->start().position_m().y(), 2);
  EXPECT_DOUBLE_EQ(replan->start().velocity_mps().x(), 3);
  EXPECT_DOUBLE_EQ(replan->start().velocity_mps().y(), -3);
  EXPECT_DOUBLE_EQ(replan->start().acceleration_mps2().x(), 2);
  EXPECT_DOUBLE_EQ(replan->start().acceleration_mps2().y(), -6);
  EXPECT_EQ(replan->warm_start().elapsed_s(), 1.0);
  EXPECT_EQ(replan->warm_start().trajectory().pieces_size(), 2);
  // Everything else is the caller's request.
  EXPECT_EQ(replan->map_id(), "demo");
  EXPECT_EQ(replan->goal().position_m().x(), 12);
  EXPECT_EQ(replan->options().time_budget_s(), 1.5);
}

TEST(MakeReplanRequest, ATimePastTheEndIsTheEnd) {
  const auto replan = MakeReplanRequest(Original(), Followed(), 10.0);
  ASSERT_TRUE(replan.ok());
  EXPECT_EQ(replan->warm_start().elapsed_s(), 4.0);
  EXPECT_DOUBLE_EQ(replan->start().position_m().x(), 6 + 10 + 4);
}

TEST(MakeReplanRequest, RefusesWhatCannotBeFollowed) {
  EXPECT_THAT(MakeReplanRequest(Original(), Followed(), std::nan("")).error().message,
              HasSubstr("elapsed_s"));
  v1::PlanResponse broken = Followed();
  broken.mutable_trajectory()->mutable_pieces(1)->set_duration_s(-1);
  EXPECT_THAT(MakeReplanRequest(Original(), broken, 1.0).error().message,
              HasSubstr("pieces[1].duration_s"));
}

}  // namespace
}  // namespace strata::client
