#include "common/job_threads.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <system_error>
#include <utility>

namespace strata::server {

JobThreads::JobThreads(int threads, std::size_t stack_bytes, std::size_t max_queued, int niceness)
    : stack_bytes_(std::max<std::size_t>(stack_bytes, PTHREAD_STACK_MIN)),
      max_queued_(max_queued),
      niceness_(niceness) {
  pthread_attr_t attributes;
  pthread_attr_init(&attributes);
  pthread_attr_setstacksize(&attributes, stack_bytes_);
  for (int i = 0; i < std::max(1, threads); ++i) {
    pthread_t thread;
    if (const int error = pthread_create(&thread, &attributes, &JobThreads::Run, this);
        error != 0) {
      pthread_attr_destroy(&attributes);
      Stop();
      throw std::system_error(error, std::generic_category(), "starting a job thread");
    }
    threads_.push_back(thread);
  }
  pthread_attr_destroy(&attributes);
}

JobThreads::~JobThreads() { Stop(); }

bool JobThreads::Post(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() >= max_queued_) return false;
    queue_.push_back(std::move(job));
  }
  changed_.notify_all();  // A thread to run it; WaitIdle waits on the same variable.
  return true;
}

void JobThreads::WaitIdle() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return queue_.empty() && running_ == 0; });
}

void JobThreads::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  for (const pthread_t thread : threads_) pthread_join(thread, nullptr);
  threads_.clear();
}

void* JobThreads::Run(void* data) {
  auto* self = static_cast<JobThreads*>(data);
  // Linux gives each thread a nice value of its own (the process's is its first thread's).
  if (self->niceness_ != 0) setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), self->niceness_);
  while (true) {
    std::function<void()> job;
    {
      std::unique_lock lock(self->mutex_);
      self->changed_.wait(lock, [self] { return self->stopping_ || !self->queue_.empty(); });
      if (self->queue_.empty()) return nullptr;  // Stopping, and nothing is left to run.
      job = std::move(self->queue_.front());
      self->queue_.pop_front();
      ++self->running_;
    }
    job();
    job = nullptr;  // What it holds is let go before anyone is told it ran.
    {
      std::lock_guard lock(self->mutex_);
      --self->running_;
    }
    self->changed_.notify_all();
  }
}

}  // namespace strata::server
