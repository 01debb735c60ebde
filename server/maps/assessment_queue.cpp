#include "maps/assessment_queue.hpp"

#include <algorithm>
#include <utility>

namespace strata::server {

AssessmentQueue::AssessmentQueue(int slots) {
  threads_.reserve(static_cast<std::size_t>(std::max(1, slots)));
  for (int i = 0; i < std::max(1, slots); ++i) threads_.emplace_back([this] { Loop(); });
}

AssessmentQueue::~AssessmentQueue() {
  Shutdown();
  for (std::thread& thread : threads_) thread.join();
}

bool AssessmentQueue::Post(Job job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    waiting_.push_back(std::move(job));
  }
  changed_.notify_all();
  return true;
}

void AssessmentQueue::Shutdown() {
  std::deque<Job> dropped;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    dropped.swap(waiting_);
  }
  changed_.notify_all();
  for (Job& job : dropped) {
    if (job.drop) job.drop();
  }
}

bool AssessmentQueue::WaitIdle(std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  return changed_.wait_until(lock, deadline, [this] { return running_ == 0; });
}

int AssessmentQueue::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

int AssessmentQueue::waiting() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(waiting_.size());
}

void AssessmentQueue::Loop() {
  while (true) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return stopping_ || !waiting_.empty(); });
      if (stopping_) return;
      job = std::move(waiting_.front());
      waiting_.pop_front();
      ++running_;
    }
    job.run();
    {
      std::lock_guard lock(mutex_);
      --running_;
    }
    changed_.notify_all();
  }
}

}  // namespace strata::server
