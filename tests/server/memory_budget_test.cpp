// The server's one memory budget (memory_budget.hpp): reservations and maps under one limit,
// refusals that give the figures, and maps let go before anything is refused.
#include "maps/memory_budget.hpp"

#include <algorithm>
#include <atomic>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using Use = MemoryBudget::Use;

constexpr std::uint64_t kMiB = 1 << 20;

// A cache holding `maps` bytes of maps: a trim records its target in `targets` and lets go down
// to it, but not below `held_by_plans` (what plans still use).
void WatchTrims(MemoryBudget& budget, std::atomic<std::uint64_t>& maps,
                std::vector<std::uint64_t>& targets, std::uint64_t held_by_plans = 0) {
  budget.WatchMaps([&maps] { return maps.load(); },
                   [&maps, &targets, held_by_plans](std::uint64_t target) {
                     targets.push_back(target);
                     maps = std::max(target, held_by_plans);
                   });
}

TEST(MemoryBudgetTest, ReservationsFitTheLimitAndGoBackWhenReleased) {
  MemoryBudget budget(100 * kMiB);
  Result<MemoryBudget::Reservation> upload = budget.Reserve(Use::kUploads, 60 * kMiB, "upload");
  ASSERT_TRUE(upload.ok());
  EXPECT_EQ(budget.reserved(Use::kUploads), 60 * kMiB);
  {
    Result<MemoryBudget::Reservation> making =
        budget.Reserve(Use::kAssessments, 40 * kMiB, "making");
    ASSERT_TRUE(making.ok());
    EXPECT_EQ(budget.MapAllowance(), 0u);
    EXPECT_FALSE(budget.Reserve(Use::kUploads, 1, "one more byte").ok());
  }  // Released.
  EXPECT_EQ(budget.reserved(Use::kAssessments), 0u);
  EXPECT_EQ(budget.MapAllowance(), 40 * kMiB);

  ASSERT_TRUE(upload.value().Grow(30 * kMiB, "upload").ok());
  EXPECT_EQ(upload.value().bytes(), 90 * kMiB);
  const ServiceStatus too_much = upload.value().Grow(20 * kMiB, "upload");
  ASSERT_FALSE(too_much.ok());
  EXPECT_EQ(upload.value().bytes(), 90 * kMiB);  // Unchanged by a refusal.

  MemoryBudget::Reservation moved = std::move(upload).value();
  EXPECT_EQ(budget.reserved(Use::kUploads), 90 * kMiB);
  moved.Release();
  EXPECT_EQ(budget.reserved(Use::kUploads), 0u);
}

TEST(MemoryBudgetTest, ARefusalNamesWhatAndGivesTheFigures) {
  MemoryBudget budget(100 * kMiB);
  std::atomic<std::uint64_t> maps{30 * kMiB};
  budget.WatchMaps([&maps] { return maps.load(); }, {});
  Result<MemoryBudget::Reservation> upload = budget.Reserve(Use::kUploads, 20 * kMiB, "upload");
  ASSERT_TRUE(upload.ok());
  const Result<MemoryBudget::Reservation> refused =
      budget.Reserve(Use::kAssessments, 64 * kMiB, "making map 'site'");
  ASSERT_FALSE(refused.ok());
  const ServiceError& error = refused.error();
  EXPECT_EQ(std::get<ErrorCode>(error.code), ErrorCode::kResourceExhausted);
  EXPECT_THAT(error.message, HasSubstr("making map 'site' needs 64.0 MiB"));
  EXPECT_THAT(error.message, HasSubstr("--max-memory 100.0 MiB) has 50.0 MiB free"));
  EXPECT_THAT(error.message, HasSubstr("maps held 30.0 MiB"));
  EXPECT_THAT(error.message, HasSubstr("uploads and maps waiting 20.0 MiB"));
  EXPECT_EQ(error.metadata.at("needed_bytes"), std::to_string(64 * kMiB));
  EXPECT_EQ(error.metadata.at("free_bytes"), std::to_string(50 * kMiB));

  // Maps count but are not reserved: AdmitMap asks, and sets nothing aside.
  EXPECT_TRUE(budget.AdmitMap(50 * kMiB, "holding map 'a'").ok());
  EXPECT_FALSE(budget.AdmitMap(50 * kMiB + 1, "holding map 'a'").ok());
  EXPECT_EQ(budget.reserved(Use::kUploads) + budget.reserved(Use::kAssessments), 20 * kMiB);
}

TEST(MemoryBudgetTest, MapsAreTrimmedToMakeRoomBeforeARefusal) {
  MemoryBudget budget(100 * kMiB);
  std::atomic<std::uint64_t> maps{90 * kMiB};
  std::vector<std::uint64_t> targets;
  WatchTrims(budget, maps, targets, 20 * kMiB);  // Plans hold 20 MiB of the maps.
  Result<MemoryBudget::Reservation> upload = budget.Reserve(Use::kUploads, 50 * kMiB, "upload");
  ASSERT_TRUE(upload.ok());
  ASSERT_EQ(targets.size(), 1u);
  EXPECT_EQ(targets[0], 50 * kMiB);  // 100 less the 50 wanted.
  EXPECT_EQ(maps.load(), 50 * kMiB);

  // Trimming cannot free enough: refused after trying.
  const Result<MemoryBudget::Reservation> refused =
      budget.Reserve(Use::kAssessments, 40 * kMiB, "making");
  ASSERT_FALSE(refused.ok());
  ASSERT_EQ(targets.size(), 2u);
  EXPECT_EQ(targets[1], 10 * kMiB);
  EXPECT_THAT(refused.error().message, HasSubstr("maps held 20.0 MiB"));

  // No trim is asked when it fits.
  ASSERT_TRUE(budget.Reserve(Use::kAssessments, 30 * kMiB, "making").ok());
  EXPECT_EQ(targets.size(), 2u);
}

TEST(MemoryBudgetTest, MapsThatGrewPastWhatIsLeftAreTrimmedBackToIt) {
  MemoryBudget budget(100 * kMiB);
  std::atomic<std::uint64_t> maps{60 * kMiB};
  std::vector<std::uint64_t> targets;
  WatchTrims(budget, maps, targets);
  Result<MemoryBudget::Reservation> upload = budget.Reserve(Use::kUploads, 30 * kMiB, "upload");
  ASSERT_TRUE(upload.ok());
  budget.FitMaps();  // 60 MiB beside the 30 reserved fit: nothing to let go.
  EXPECT_TRUE(targets.empty());
  maps = 85 * kMiB;  // A plan's graphs grew a map after it was admitted.
  budget.FitMaps();
  ASSERT_EQ(targets.size(), 1u);
  EXPECT_EQ(targets[0], 70 * kMiB);  // 100 less the 30 reserved.

  MemoryBudget unlimited(0);
  unlimited.WatchMaps([] { return std::uint64_t{1} << 62; },
                      [&](std::uint64_t target) { targets.push_back(target); });
  unlimited.FitMaps();
  EXPECT_EQ(targets.size(), 1u);
}

TEST(MemoryBudgetTest, WithoutALimitEverythingFitsAndIsCounted) {
  MemoryBudget budget(0);
  Result<MemoryBudget::Reservation> huge =
      budget.Reserve(Use::kUploads, std::uint64_t{1} << 62, "upload");
  ASSERT_TRUE(huge.ok());
  EXPECT_TRUE(huge.value().Grow(std::uint64_t{1} << 62, "upload").ok());
  EXPECT_EQ(budget.reserved(Use::kUploads), std::uint64_t{1} << 63);
  EXPECT_EQ(budget.MapAllowance(), std::numeric_limits<std::uint64_t>::max());
  EXPECT_TRUE(budget.AdmitMap(std::uint64_t{1} << 62, "map").ok());
}

TEST(MemoryBudgetTest, ConcurrentReservationsNeverPassTheLimit) {
  constexpr std::uint64_t kLimit = 64 * kMiB;
  MemoryBudget budget(kLimit);
  std::atomic<bool> over{false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 2000; ++i) {
        Result<MemoryBudget::Reservation> r = budget.Reserve(Use::kUploads, 5 * kMiB, "upload");
        if (budget.reserved(Use::kUploads) > kLimit) over = true;
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_FALSE(over.load());
  EXPECT_EQ(budget.reserved(Use::kUploads), 0u);
}

TEST(MemoryBudgetTest, TheAutomaticLimitIsAtMostFourFifthsOfTheMachine) {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  meminfo >> key >> kib;
  ASSERT_EQ(key, "MemTotal:");
  const std::uint64_t limit = AutomaticMemoryLimit();
  EXPECT_GT(limit, 0u);
  EXPECT_LE(limit, kib * 1024 / 5 * 4);  // Less when a cgroup limits the process.
}

}  // namespace
}  // namespace strata::server
