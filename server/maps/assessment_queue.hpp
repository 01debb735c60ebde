#pragma once
/// The jobs that make maps, new maps and new versions of edited ones, run here: in order of
/// arrival, at most `slots` at a time (--max-concurrent-assessments), each on a thread of the
/// queue's own, never on an RPC thread. A job that waits costs a closure; a job that runs
/// costs a slot, whatever made it. No gRPC here.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace strata::server {

class AssessmentQueue {
 public:
  /// One job. `run` is called on a queue thread once a slot is free; `drop`, when not empty,
  /// is called instead (on the thread that called Shutdown) for a job still waiting when the
  /// queue shuts down. Neither may throw.
  struct Job {
    std::function<void()> run;
    std::function<void()> drop;
  };

  /// Starts `slots` (>= 1) threads.
  explicit AssessmentQueue(int slots);
  /// Shutdown(), then waits for the running jobs to end.
  ~AssessmentQueue();
  AssessmentQueue(const AssessmentQueue&) = delete;
  AssessmentQueue& operator=(const AssessmentQueue&) = delete;

  /// Queues `job` behind those waiting; false (and neither callable is called) after
  /// Shutdown.
  bool Post(Job job);

  /// Takes no more jobs and drops those waiting (their `drop` runs here); running jobs go on
  /// (their own stop conditions end them). Idempotent.
  void Shutdown();

  /// Blocks until no job runs or `deadline` passes; true when idle.
  bool WaitIdle(std::chrono::steady_clock::time_point deadline);

  int slots() const { return static_cast<int>(threads_.size()); }
  /// Jobs running now, and waiting for a slot.
  int running() const;
  int waiting() const;

 private:
  void Loop();

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> waiting_;
  int running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace strata::server
