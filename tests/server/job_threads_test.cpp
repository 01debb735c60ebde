// JobThreads: every job runs, on a thread whose stack is the size asked for, and the queue's
// bound and Stop hold.
#include "common/job_threads.hpp"

#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <latch>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

// The stack size of the calling thread [bytes].
std::size_t OwnStackBytes() {
  pthread_attr_t attributes;
  pthread_getattr_np(pthread_self(), &attributes);
  std::size_t bytes = 0;
  pthread_attr_getstacksize(&attributes, &bytes);
  pthread_attr_destroy(&attributes);
  return bytes;
}

// Uses `bytes` of stack in frames of 64 KiB: what a deep parser or a large local does.
std::size_t UseStack(std::size_t bytes) {
  volatile char frame[64 * 1024];
  std::memset(const_cast<char*>(frame), 1, sizeof frame);
  if (bytes <= sizeof frame) return frame[0];
  return frame[sizeof frame - 1] + UseStack(bytes - sizeof frame);
}

TEST(JobThreadsTest, JobsRunOnStacksOfTheSizeAsked) {
  constexpr std::size_t kStack = std::size_t{8} << 20;
  JobThreads threads(2, kStack, 16);
  EXPECT_EQ(threads.stack_bytes(), kStack);
  std::atomic<std::size_t> seen{0};
  std::latch done(2);
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(threads.Post([&] {
      seen = OwnStackBytes();
      // 4 MiB of frames: far beyond the 100 KiB a civetweb thread had.
      EXPECT_GT(UseStack(std::size_t{4} << 20), 0u);
      done.count_down();
    }));
  }
  done.wait();
  EXPECT_GE(seen.load(), kStack);
}

TEST(JobThreadsTest, TheQueueIsBoundedAndStopRunsWhatWaits) {
  JobThreads threads(1, 1 << 20, 2);
  std::latch release(1);
  std::latch started(1);
  std::atomic<int> ran{0};
  ASSERT_TRUE(threads.Post([&] {
    started.count_down();
    release.wait();
    ++ran;
  }));
  started.wait();  // The one thread is busy: two more may wait, a third may not.
  EXPECT_TRUE(threads.Post([&] { ++ran; }));
  EXPECT_TRUE(threads.Post([&] { ++ran; }));
  EXPECT_FALSE(threads.Post([&] { ++ran; }));
  release.count_down();
  threads.Stop();
  EXPECT_EQ(ran.load(), 3);
  EXPECT_FALSE(threads.Post([&] { ++ran; }));
}

TEST(JobThreadsTest, WaitIdleReturnsOnceEveryQueuedJobHasRun) {
  JobThreads threads(1, 1 << 20, 8);
  std::atomic<int> ran{0};
  for (int k = 0; k < 8; ++k) ASSERT_TRUE(threads.Post([&] { ++ran; }));
  threads.WaitIdle();
  EXPECT_EQ(ran.load(), 8);
  threads.WaitIdle();  // Idle already: returns at once.
}

TEST(JobThreadsTest, ThreadsRunAtTheNiceValueAsked) {
  const int own = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  JobThreads background(1, 1 << 20, 1, 19);
  JobThreads plain(1, 1 << 20, 1);
  std::atomic<int> background_nice{-100}, plain_nice{-100};
  ASSERT_TRUE(background.Post(
      [&] { background_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())); }));
  ASSERT_TRUE(
      plain.Post([&] { plain_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())); }));
  background.WaitIdle();
  plain.WaitIdle();
  EXPECT_EQ(background_nice.load(), 19);
  EXPECT_EQ(plain_nice.load(), own);  // Left as the thread that started it was.
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())), own);
}

}  // namespace
}  // namespace strata::server
