// The ring of recent plans (server/rpc/recent_plans.hpp): newest first, bounded in count and in
// bytes whatever is recorded, large plans trimmed instead of evicting everything.
#include "rpc/recent_plans.hpp"

#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

v1::RecentPlan Answered(const std::string& map_id, int pieces = 1) {
  v1::RecentPlan plan;
  plan.mutable_request()->set_map_id(map_id);
  plan.set_transport("grpc");
  v1::Trajectory* trajectory = plan.mutable_response()->mutable_trajectory();
  for (int i = 0; i < pieces; ++i) {
    v1::TrajectoryPiece* piece = trajectory->add_pieces();
    piece->set_duration_s(1.0);
    for (int axis = 0; axis < 3; ++axis) {
      for (int k = 0; k < 6; ++k) piece->add_axes()->add_coefficients(0.5 * k + axis);
    }
  }
  return plan;
}

std::vector<std::string> MapIds(const RecentPlans& recent, std::size_t max_plans = 0) {
  v1::ListRecentPlansResponse response;
  recent.List(max_plans, &response);
  std::vector<std::string> ids;
  for (const v1::RecentPlan& plan : response.plans()) ids.push_back(plan.request().map_id());
  return ids;
}

TEST(RecentPlansTest, KeepsTheNewestFirstUpToItsCount) {
  RecentPlans recent(3, 1 << 20);
  for (const char* id : {"a", "b", "c", "d"}) recent.Record(Answered(id));
  EXPECT_EQ(MapIds(recent), (std::vector<std::string>{"d", "c", "b"}));
  EXPECT_EQ(MapIds(recent, 2), (std::vector<std::string>{"d", "c"}));
  EXPECT_EQ(MapIds(recent, 10).size(), 3u);
}

TEST(RecentPlansTest, StaysWithinItsBytesAndTrimsLargePlans) {
  constexpr std::size_t kMaxBytes = 64 << 10;
  RecentPlans recent(100, kMaxBytes);
  const v1::RecentPlan small = Answered("small", 10);
  const std::size_t small_bytes = small.ByteSizeLong();
  ASSERT_LT(small_bytes, kMaxBytes / 8);
  for (int i = 0; i < 200; ++i) recent.Record(small);
  EXPECT_LE(recent.bytes(), kMaxBytes);
  EXPECT_GE(recent.bytes(), kMaxBytes - small_bytes);  // Full: only the oldest went.

  // A plan above an eighth of the bytes is kept without its trajectory, and evicts few.
  const v1::RecentPlan large = Answered("large", 2000);
  ASSERT_GT(large.ByteSizeLong(), kMaxBytes);
  recent.Record(large);
  v1::ListRecentPlansResponse response;
  recent.List(1, &response);
  ASSERT_EQ(response.plans_size(), 1);
  EXPECT_EQ(response.plans(0).request().map_id(), "large");
  EXPECT_TRUE(response.plans(0).trimmed());
  EXPECT_FALSE(response.plans(0).response().has_trajectory());
  EXPECT_LE(recent.bytes(), kMaxBytes);
  EXPECT_GT(MapIds(recent).size(), 10u);

  // A request of huge strings keeps nothing but its map id, cut.
  v1::RecentPlan strings = Answered(std::string(1 << 20, 'm'));
  strings.mutable_request()->set_profile_name(std::string(1 << 20, 'p'));
  recent.Record(strings);
  EXPECT_LE(recent.bytes(), kMaxBytes);
  response.Clear();
  recent.List(1, &response);
  EXPECT_TRUE(response.plans(0).trimmed());
  EXPECT_LT(response.plans(0).request().map_id().size(), 200u);
  EXPECT_TRUE(response.plans(0).request().profile_name().empty());
}

TEST(RecentPlansTest, RecordsFromManyThreads) {
  RecentPlans recent(8, 1 << 20);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&recent, t] {
      for (int i = 0; i < 100; ++i) recent.Record(Answered("t" + std::to_string(t)));
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(MapIds(recent).size(), 8u);
}

}  // namespace
}  // namespace strata::server
