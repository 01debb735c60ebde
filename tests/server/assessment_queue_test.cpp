// The assessment queue: jobs run in order of arrival, never more at once than its slots, and
// a shutdown drops what waits (each dropped job told) while what runs finishes.
#include "maps/assessment_queue.hpp"

#include <atomic>
#include <future>
#include <mutex>
#include <vector>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

// Jobs that hold their slot until the test releases them, counting how many run at once.
class HeldJobs {
 public:
  AssessmentQueue::Job Job(int index) {
    return {[this, index] {
              {
                std::unique_lock lock(mutex_);
                started_.push_back(index);
                most_ = std::max(most_, ++running_);
                changed_.notify_all();
                changed_.wait(lock, [&] { return released_ > 0; });
                --released_;
                --running_;
              }
              changed_.notify_all();
            },
            [this, index] {
              std::lock_guard lock(mutex_);
              dropped_.push_back(index);
            }};
  }
  // Waits until `count` jobs have started, then lets one of them finish.
  void ReleaseOneAfter(int started) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return static_cast<int>(started_.size()) >= started; });
    ++released_;
    changed_.notify_all();
  }
  void WaitRunning(int count) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return running_ == count; });
  }
  std::vector<int> started() {
    std::lock_guard lock(mutex_);
    return started_;
  }
  std::vector<int> dropped() {
    std::lock_guard lock(mutex_);
    return dropped_;
  }
  int most() {
    std::lock_guard lock(mutex_);
    return most_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<int> started_;
  std::vector<int> dropped_;
  int running_ = 0;
  int most_ = 0;
  int released_ = 0;
};

TEST(AssessmentQueueTest, RunsJobsInOrderNeverMoreAtOnceThanItsSlots) {
  for (const int slots : {1, 2}) {
    HeldJobs jobs;
    AssessmentQueue queue(slots);
    EXPECT_EQ(queue.slots(), slots);
    constexpr int kJobs = 6;
    for (int i = 0; i < kJobs; ++i) ASSERT_TRUE(queue.Post(jobs.Job(i)));
    jobs.WaitRunning(slots);
    EXPECT_EQ(queue.running(), slots);
    EXPECT_EQ(queue.waiting(), kJobs - slots);
    for (int done = 0; done < kJobs; ++done) jobs.ReleaseOneAfter(std::min(kJobs, done + slots));
    EXPECT_TRUE(queue.WaitIdle(std::chrono::steady_clock::time_point::max()));
    EXPECT_EQ(jobs.most(), slots);
    const std::vector<int> started = jobs.started();
    ASSERT_EQ(started.size(), static_cast<std::size_t>(kJobs));
    if (slots == 1) EXPECT_EQ(started, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  }
}

TEST(AssessmentQueueTest, AShutdownDropsTheWaitingJobsAndLetsTheRunningOneFinish) {
  HeldJobs jobs;
  AssessmentQueue queue(1);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(queue.Post(jobs.Job(i)));
  jobs.WaitRunning(1);
  queue.Shutdown();
  EXPECT_EQ(jobs.dropped(), (std::vector<int>{1, 2}));
  EXPECT_FALSE(queue.Post(jobs.Job(3)));  // Neither run nor dropped.
  jobs.ReleaseOneAfter(1);
  EXPECT_TRUE(queue.WaitIdle(std::chrono::steady_clock::time_point::max()));
  EXPECT_EQ(jobs.started(), (std::vector<int>{0}));
  EXPECT_EQ(jobs.dropped(), (std::vector<int>{1, 2}));
}

}  // namespace
}  // namespace strata::server
