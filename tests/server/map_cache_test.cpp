// MapCache: one load per version however many ask at once, least recently used maps dropped
// when over the budget but never one a caller still holds (this test also runs under
// ThreadSanitizer).
#include "maps/map_cache.hpp"

#include <atomic>
#include <future>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

// A flat floor of `side` x `side` points every 5 cm: its model's bytes grow with the side.
std::shared_ptr<const PlanningMap> Floor(int side) {
  PointCloud cloud;
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) cloud.emplace_back(0.05f * i, 0.05f * j, 0.0f);
  }
  AssessmentConfig config;
  config.num_threads = 1;
  return std::make_shared<PlanningMap>(TerrainModel::Assess(cloud, config).value());
}

// Loads a fresh floor of `side` points a side, which only the cache (and its callers) hold.
MapCache::Loader CountingLoader(int side, std::atomic<int>* loads) {
  return [side, loads]() -> Result<std::shared_ptr<const PlanningMap>> {
    ++*loads;
    return Floor(side);
  };
}

TEST(MapCacheTest, ConcurrentRequestsForOneVersionShareOneLoad) {
  MapCache cache;
  std::atomic<int> loads{0};
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  const auto map = Floor(40);
  // The loader waits until every caller has asked, so they all overlap it.
  const MapCache::Loader slow = [&]() -> Result<std::shared_ptr<const PlanningMap>> {
    ++loads;
    released.wait();
    return map;
  };
  std::vector<std::future<Result<std::shared_ptr<const PlanningMap>>>> callers;
  for (int i = 0; i < 8; ++i) {
    callers.push_back(std::async(std::launch::async, [&] { return cache.Get("m", "v1", slow); }));
  }
  while (loads.load() == 0) std::this_thread::yield();
  release.set_value();
  for (auto& caller : callers) {
    Result<std::shared_ptr<const PlanningMap>> got = caller.get();
    ASSERT_TRUE(got.ok());
    EXPECT_EQ(got.value(), map);
  }
  EXPECT_EQ(loads.load(), 1);
  EXPECT_EQ(cache.Count(), 1);
}

TEST(MapCacheTest, AFailedLoadIsNotRememberedAndNextCallerRetries) {
  MapCache cache;
  int attempts = 0;
  const auto map = Floor(20);
  const MapCache::Loader flaky = [&]() -> Result<std::shared_ptr<const PlanningMap>> {
    if (++attempts == 1) return MakeError(ServiceErrorCode::kMapStoreUnavailable, "flaky");
    return map;
  };
  EXPECT_FALSE(cache.Get("m", "v1", flaky).ok());
  EXPECT_EQ(cache.Count(), 0);
  EXPECT_TRUE(cache.Get("m", "v1", flaky).ok());
  EXPECT_EQ(attempts, 2);
}

TEST(MapCacheTest, DropsLeastRecentlyUsedWithinTheBudgetButNeverAHeldMap) {
  const std::uint64_t one = Floor(60)->MemoryBytes();
  const std::uint64_t budget = 2 * one + one / 2;  // Room for two.
  MapCache cache([budget] { return budget; });
  std::atomic<int> loads{0};
  ASSERT_TRUE(cache.Get("a", "v", CountingLoader(60, &loads)).ok());
  ASSERT_TRUE(cache.Get("b", "v", CountingLoader(60, &loads)).ok());
  ASSERT_TRUE(cache.Get("a", "v", CountingLoader(60, &loads)).ok());  // a is now the newest.
  ASSERT_TRUE(cache.Get("c", "v", CountingLoader(60, &loads)).ok());  // Drops b, the oldest.
  EXPECT_EQ(loads.load(), 3);
  EXPECT_LE(cache.ResidentBytes(), budget);
  EXPECT_NE(cache.Peek("a", "v"), nullptr);
  EXPECT_EQ(cache.Peek("b", "v"), nullptr);

  // A caller holds a (as a plan would): loading b again drops c, not a, though a is older.
  Result<std::shared_ptr<const PlanningMap>> held = cache.Get("a", "v", CountingLoader(60, &loads));
  ASSERT_TRUE(cache.Get("c", "v", CountingLoader(60, &loads)).ok());  // c newest, a older.
  ASSERT_TRUE(cache.Get("b", "v", CountingLoader(60, &loads)).ok());
  EXPECT_NE(cache.Peek("a", "v"), nullptr);
  EXPECT_EQ(cache.Peek("c", "v"), nullptr);
  EXPECT_LE(cache.ResidentBytes(), budget);
}

TEST(MapCacheTest, AMapLargerThanTheWholeBudgetIsRefused) {
  const std::uint64_t half = Floor(60)->MemoryBytes() / 2;
  MapCache cache([half] { return half; });
  std::atomic<int> loads{0};
  const Result<std::shared_ptr<const PlanningMap>> got =
      cache.Get("big", "v", CountingLoader(60, &loads));
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(std::get<ErrorCode>(got.error().code), ErrorCode::kResourceExhausted);
  EXPECT_NE(got.error().message.find("--max-memory"), std::string::npos);
  EXPECT_EQ(cache.Count(), 0);
}

TEST(MapCacheTest, FollowsAnAllowanceThatShrinksAndTrimsForOtherUses) {
  const std::uint64_t one = Floor(60)->MemoryBytes();
  std::atomic<std::uint64_t> allowance{3 * one};
  MapCache cache([&allowance] { return allowance.load(); });
  std::atomic<int> loads{0};
  for (const char* id : {"a", "b", "c"}) {
    ASSERT_TRUE(cache.Get(id, "v", CountingLoader(60, &loads)).ok());
  }
  EXPECT_EQ(cache.Count(), 3);
  // Memory went to other uses: the next load makes room down to the new allowance.
  allowance = 2 * one;
  ASSERT_TRUE(cache.Get("d", "v", CountingLoader(60, &loads)).ok());
  EXPECT_EQ(cache.Count(), 2);
  EXPECT_NE(cache.Peek("d", "v"), nullptr);
  EXPECT_NE(cache.Peek("c", "v"), nullptr);

  // Trimming for another use may drop even the newest, but never a held map.
  Result<std::shared_ptr<const PlanningMap>> held = cache.Get("c", "v", CountingLoader(60, &loads));
  cache.TrimTo(0);
  EXPECT_EQ(cache.Count(), 1);
  EXPECT_NE(cache.Peek("c", "v"), nullptr);
  EXPECT_EQ(cache.Peek("d", "v"), nullptr);
}

// Robots' scans edit a map every second: without a budget the cache held every version made.
// A version made here forgets the others of its map; a plan holding one keeps it, and a later
// request for it loads it again.
TEST(MapCacheTest, AVersionMadeHereForgetsTheOthersOfItsMap) {
  MapCache cache;
  std::atomic<int> loads{0};
  Result<std::shared_ptr<const PlanningMap>> held =
      cache.Get("m", "v1", CountingLoader(20, &loads));
  ASSERT_TRUE(held.ok());
  ASSERT_TRUE(cache.Get("other", "v1", CountingLoader(20, &loads)).ok());
  cache.Hold("m", "v2", Floor(20));
  cache.MarkPublished("m", "v2");
  cache.Hold("m", "v3", Floor(20));
  cache.MarkPublished("m", "v3");
  EXPECT_EQ(cache.Count(), 2);
  EXPECT_EQ(cache.Peek("m", "v1"), nullptr);
  EXPECT_EQ(cache.Peek("m", "v2"), nullptr);
  EXPECT_NE(cache.Peek("m", "v3"), nullptr);
  EXPECT_NE(cache.Peek("other", "v1"), nullptr);
  EXPECT_NE(held.value(), nullptr);  // The plan on v1 still has it.
  ASSERT_TRUE(cache.Get("m", "v1", CountingLoader(20, &loads)).ok());
  EXPECT_EQ(loads, 3);  // Loaded again.
}

// A request for a version just published can come before the editor holds it here: its load
// of the saved model (which has no graphs) must not replace the map the editor made, whose
// robots' graphs were built ahead.
TEST(MapCacheTest, AMapHeldWhileItsVersionLoadsIsTheOneKept) {
  MapCache cache;
  std::promise<void> loading, release;
  std::shared_future<void> released = release.get_future().share();
  auto request = std::async(std::launch::async, [&] {
    return cache.Get("m", "v2", [&]() -> Result<std::shared_ptr<const PlanningMap>> {
      loading.set_value();
      released.wait();
      return Floor(20);
    });
  });
  loading.get_future().wait();
  const std::shared_ptr<const PlanningMap> made = Floor(20);
  cache.Hold("m", "v2", made);
  cache.MarkPublished("m", "v2");
  // The next edit builds on the map made here (its graphs), while the load still runs.
  EXPECT_EQ(cache.Peek("m", "v2"), made);
  cache.Forget("m", "v2");  // Not while loading: the loader finds its slot.
  release.set_value();
  const Result<std::shared_ptr<const PlanningMap>> got = request.get();
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got.value(), made);
  EXPECT_EQ(cache.Peek("m", "v2"), made);
  EXPECT_EQ(cache.Count(), 1);
}

// An editor holds the version it made before publishing it: the first request for the new
// head finds it, graphs and all, and loads nothing, while the version before stays held until
// the new one is published (or is forgotten when publishing fails).
TEST(MapCacheTest, AVersionHeldBeforeItIsPublishedIsFoundWithoutALoad) {
  MapCache cache;
  std::atomic<int> loads{0};
  const Result<std::shared_ptr<const PlanningMap>> v1 =
      cache.Get("m", "v1", CountingLoader(20, &loads));
  ASSERT_TRUE(v1.ok());
  const std::shared_ptr<const PlanningMap> made = Floor(20);
  EXPECT_TRUE(cache.Hold("m", "v2", made));
  EXPECT_FALSE(cache.Hold("m", "v2", made));  // Held already.
  EXPECT_EQ(cache.Peek("m", "v1"), v1.value());
  const Result<std::shared_ptr<const PlanningMap>> v2 =
      cache.Get("m", "v2", CountingLoader(20, &loads));
  ASSERT_TRUE(v2.ok());
  EXPECT_EQ(v2.value(), made);
  EXPECT_EQ(loads, 1);  // v1's alone.

  EXPECT_TRUE(cache.Hold("m", "v3", Floor(20)));
  cache.Forget("m", "v3");  // Its publishing failed.
  EXPECT_EQ(cache.Peek("m", "v3"), nullptr);
  EXPECT_EQ(cache.Count(), 2);

  cache.MarkPublished("m", "v2");  // Held above; published: the one current version.
  EXPECT_EQ(cache.Peek("m", "v1"), nullptr);
  EXPECT_EQ(cache.Peek("m", "v2"), made);
  EXPECT_EQ(cache.Count(), 1);
}

TEST(MapCacheTest, DropForgetsEveryVersionOfAMap) {
  MapCache cache;
  std::atomic<int> loads{0};
  ASSERT_TRUE(cache.Get("m", "v1", CountingLoader(20, &loads)).ok());
  cache.Hold("m", "v2", Floor(20));
  cache.MarkPublished("m", "v2");
  ASSERT_TRUE(cache.Get("other", "v1", CountingLoader(20, &loads)).ok());
  cache.Drop("m");
  EXPECT_EQ(cache.Peek("m", "v1"), nullptr);
  EXPECT_EQ(cache.Peek("m", "v2"), nullptr);
  EXPECT_NE(cache.Peek("other", "v1"), nullptr);
}

}  // namespace
}  // namespace strata::server
