#pragma once
/// Admission to a fixed number of slots (plans running at once) through a first-come,
/// first-served queue of bounded length: a released slot goes to the longest waiter, a full
/// queue refuses at once, and each waiter gives up at its own deadline or when its call is
/// cancelled. Bounds both the work in progress and the calls held waiting, without turning
/// a burst into errors.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <list>
#include <mutex>

namespace strata::server {

class ConcurrencyLimiter {
 public:
  /// `slots` >= 1 run at once; at most `max_queued` >= 0 wait.
  ConcurrencyLimiter(int slots, int max_queued);

  enum class Admission {
    kAdmitted,   ///< A slot is held: release it with Release() (or hold it with a Slot).
    kQueueFull,  ///< `max_queued` calls were already waiting.
    kTimedOut,   ///< `deadline` passed while waiting.
    kStopped,    ///< `should_stop` returned true while waiting.
  };

  /// Takes a free slot when no one waits, else queues behind the earlier callers until a
  /// slot is handed over, `deadline` passes, or `should_stop` (may be empty; polled every
  /// 50 ms, since a call's cancellation has no notification) returns true.
  Admission Acquire(std::chrono::steady_clock::time_point deadline,
                    const std::function<bool()>& should_stop);
  /// Takes a slot only if one is free (so no one waits); never queues. For work that may use
  /// idle slots but must not take a turn from a waiting caller (EstimateCosts' extra threads).
  bool TryAcquire();
  /// Hands the slot to the longest waiter, or frees it.
  void Release();

  int slots() const { return slots_; }
  int max_queued() const { return max_queued_; }
  /// Calls waiting now (for tests and metrics).
  std::size_t queued() const;
  /// Slots held now (for metrics).
  int busy() const;

  /// Holds a slot for a scope.
  class Slot {
   public:
    explicit Slot(ConcurrencyLimiter* limiter) : limiter_(limiter) {}
    ~Slot() {
      if (limiter_ != nullptr) limiter_->Release();
    }
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;

   private:
    ConcurrencyLimiter* limiter_;
  };

 private:
  struct Waiter {
    std::condition_variable granted_cv;
    bool granted = false;
  };

  const int slots_;
  const int max_queued_;
  mutable std::mutex mutex_;
  int free_;
  std::list<Waiter> queue_;  // Oldest first; a list, so a waiter's node stays put.
};

}  // namespace strata::server
