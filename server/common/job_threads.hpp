#pragma once
/// A fixed set of threads, each with a stack of a size given here rather than one a library or
/// the environment picks, that run queued jobs in the order they arrive. The HTTP server
/// answers its requests on them (http_server.hpp): the work behind an API call (loading a map
/// from the store, planning) needs the stack a gRPC thread has, which an event loop's or a web
/// library's threads do not promise. A map store's graphs are written on one, at the least CPU
/// priority (maps/graph_writer.hpp).
#include <pthread.h>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <vector>

namespace strata::server {

class JobThreads {
 public:
  /// Starts `threads` (>= 1) threads with stacks of `stack_bytes` each (at least
  /// PTHREAD_STACK_MIN); at most `max_queued` jobs wait for one. Each thread runs at nice value
  /// `niceness` (setpriority; 0: the process's own, up to 19: the least CPU priority, for work
  /// that nothing waits for); a value the process may not take leaves the thread as it was.
  /// Throws std::system_error when a thread cannot be started.
  JobThreads(int threads, std::size_t stack_bytes, std::size_t max_queued, int niceness = 0);
  /// Stop().
  ~JobThreads();
  JobThreads(const JobThreads&) = delete;
  JobThreads& operator=(const JobThreads&) = delete;

  /// Queues `job`; false (and `job` is not run) when `max_queued` jobs already wait, or after
  /// Stop(). A job must not throw: an exception that leaves it ends the process, as on any
  /// thread.
  bool Post(std::function<void()> job);

  /// Returns once no job waits and none runs (every job queued so far has run).
  void WaitIdle();

  /// Refuses new jobs, runs every job already queued, and joins the threads. Idempotent.
  void Stop();

  /// The stack size every thread was started with [bytes].
  std::size_t stack_bytes() const { return stack_bytes_; }

 private:
  static void* Run(void* self);

  std::size_t stack_bytes_;
  std::size_t max_queued_;
  int niceness_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> queue_;
  int running_ = 0;  // Jobs taken from the queue and not yet done.
  bool stopping_ = false;
  std::vector<pthread_t> threads_;
};

}  // namespace strata::server
