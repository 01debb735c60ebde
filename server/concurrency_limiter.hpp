#pragma once
/// A counting semaphore whose waiters give up at a deadline or when their call is
/// cancelled: bounds how many plans run at once without turning a burst into errors.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>

namespace strata::server {

class ConcurrencyLimiter {
 public:
  /// `slots` >= 1.
  explicit ConcurrencyLimiter(int slots) : free_(slots < 1 ? 1 : slots) {}

  /// Takes a slot, waiting until `deadline` or until `should_stop` (may be empty; polled
  /// every 50 ms) returns true. True when a slot was taken: release it with Release().
  bool Acquire(std::chrono::steady_clock::time_point deadline,
               const std::function<bool()>& should_stop);
  void Release();

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
  std::mutex mutex_;
  std::condition_variable released_;
  int free_;
};

}  // namespace strata::server
