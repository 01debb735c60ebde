// The planning slots' queue: first come first served, bounded, each waiter's own deadline.
#include "rpc/concurrency_limiter.hpp"

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

using Admission = ConcurrencyLimiter::Admission;
using Clock = std::chrono::steady_clock;

constexpr auto kForever = Clock::time_point::max();

// Spins until `limiter` holds `n` waiters: the order in which threads queue is then known.
void WaitForQueued(const ConcurrencyLimiter& limiter, std::size_t n) {
  while (limiter.queued() != n) std::this_thread::yield();
}

TEST(ConcurrencyLimiterTest, CallsRunWhileSlotsAreFreeAndAFullQueueRefusesAtOnce) {
  ConcurrencyLimiter limiter(2, 0);
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
  // No slot and no room to wait: refused at once, whatever the deadline.
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kQueueFull);
  limiter.Release();
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
}

// TryAcquire takes only an idle slot, and never one a waiter is owed.
TEST(ConcurrencyLimiterTest, TryAcquireTakesOnlyIdleSlotsAndNeverOnesOwedToWaiters) {
  ConcurrencyLimiter limiter(2, 4);
  ASSERT_TRUE(limiter.TryAcquire());
  ASSERT_TRUE(limiter.TryAcquire());
  EXPECT_FALSE(limiter.TryAcquire());
  std::atomic<bool> admitted{false}, done{false};
  std::thread waiter([&] {
    EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
    admitted = true;
    while (!done) std::this_thread::yield();
    limiter.Release();
  });
  WaitForQueued(limiter, 1);
  limiter.Release();  // Owed to the waiter from now on, not free.
  EXPECT_FALSE(limiter.TryAcquire());
  while (!admitted) std::this_thread::yield();
  EXPECT_FALSE(limiter.TryAcquire());
  done = true;
  waiter.join();
  EXPECT_TRUE(limiter.TryAcquire());  // The waiter's, released again.
  EXPECT_FALSE(limiter.TryAcquire());
}

// A released slot goes to the longest waiter (it once went to whichever of the waiters
// polled first: at 64 clients the p99 was 8 s for plans of 73 ms).
TEST(ConcurrencyLimiterTest, SlotsGoToWaitersInTheOrderTheyCame) {
  ConcurrencyLimiter limiter(1, 16);
  ASSERT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
  std::mutex mutex;
  std::vector<int> order;
  std::vector<std::thread> waiters;
  constexpr int kWaiters = 8;
  for (int i = 0; i < kWaiters; ++i) {
    waiters.emplace_back([&, i] {
      ASSERT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
      {
        std::lock_guard lock(mutex);
        order.push_back(i);
      }
      limiter.Release();
    });
    WaitForQueued(limiter, i + 1);
  }
  limiter.Release();
  for (std::thread& t : waiters) t.join();
  std::vector<int> expected(kWaiters);
  for (int i = 0; i < kWaiters; ++i) expected[i] = i;
  EXPECT_EQ(order, expected);
}

TEST(ConcurrencyLimiterTest, TheQueueIsBoundedAndAReleasedSlotIsNotTakenByANewcomer) {
  ConcurrencyLimiter limiter(1, 2);
  ASSERT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
  std::atomic<int> admitted = 0;
  std::atomic<bool> release = false;
  std::vector<std::thread> waiters;
  for (int i = 0; i < 2; ++i) {
    waiters.emplace_back([&] {
      EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
      ++admitted;
      while (!release) std::this_thread::yield();
      limiter.Release();
    });
    WaitForQueued(limiter, i + 1);
  }
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kQueueFull);
  limiter.Release();  // To the first waiter, not to a caller arriving now.
  while (admitted != 1) std::this_thread::yield();
  // There is room to wait now, and the slot is the first waiter's: a caller arriving now
  // waits (here, until its deadline, already past).
  EXPECT_EQ(limiter.Acquire(Clock::now(), {}), Admission::kTimedOut);
  release = true;
  for (std::thread& t : waiters) t.join();
  EXPECT_EQ(admitted, 2);
  EXPECT_EQ(limiter.queued(), 0u);
  EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
}

TEST(ConcurrencyLimiterTest, AWaiterLeavesAtItsDeadlineOrWhenStoppedAndFreesItsPlace) {
  ConcurrencyLimiter limiter(1, 1);
  ASSERT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
  EXPECT_EQ(limiter.Acquire(Clock::now() + std::chrono::milliseconds(1), {}), Admission::kTimedOut);
  int polls = 0;
  EXPECT_EQ(limiter.Acquire(kForever, [&] { return ++polls >= 2; }), Admission::kStopped);
  EXPECT_EQ(polls, 2);
  EXPECT_EQ(limiter.queued(), 0u);
  // The places they left are free for the next waiter, who gets the slot when it is released.
  std::thread waiter([&] {
    EXPECT_EQ(limiter.Acquire(kForever, {}), Admission::kAdmitted);
    limiter.Release();
  });
  WaitForQueued(limiter, 1);
  limiter.Release();
  waiter.join();
}

}  // namespace
}  // namespace strata::server
