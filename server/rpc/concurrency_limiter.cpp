#include "rpc/concurrency_limiter.hpp"

#include <algorithm>

namespace strata::server {

ConcurrencyLimiter::ConcurrencyLimiter(int slots, int max_queued)
    : slots_(std::max(1, slots)), max_queued_(std::max(0, max_queued)), free_(slots_) {}

ConcurrencyLimiter::Admission ConcurrencyLimiter::Acquire(
    std::chrono::steady_clock::time_point deadline, const std::function<bool()>& should_stop) {
  constexpr auto kPollPeriod = std::chrono::milliseconds(50);
  std::unique_lock lock(mutex_);
  // Free slots exist only while no one waits ungranted (Release hands a slot over first).
  if (free_ > 0) {
    --free_;
    return Admission::kAdmitted;
  }
  if (queue_.size() >= static_cast<std::size_t>(max_queued_)) return Admission::kQueueFull;
  const auto waiter = queue_.emplace(queue_.end());
  Admission outcome = Admission::kAdmitted;
  while (!waiter->granted) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) {
      outcome = Admission::kTimedOut;
      break;
    }
    if (should_stop && should_stop()) {
      outcome = Admission::kStopped;
      break;
    }
    waiter->granted_cv.wait_until(lock,
                                  should_stop ? std::min(deadline, now + kPollPeriod) : deadline);
  }
  // A slot handed over in the same instant as the deadline is kept: the caller checks its
  // time left before planning anyway.
  if (waiter->granted) outcome = Admission::kAdmitted;
  queue_.erase(waiter);
  return outcome;
}

bool ConcurrencyLimiter::TryAcquire() {
  std::lock_guard lock(mutex_);
  // Free slots exist only while no one waits ungranted (Release hands a slot over first).
  if (free_ == 0) return false;
  --free_;
  return true;
}

void ConcurrencyLimiter::Release() {
  std::lock_guard lock(mutex_);
  for (Waiter& waiter : queue_) {
    if (waiter.granted) continue;  // Handed a slot already, not yet awake.
    waiter.granted = true;
    waiter.granted_cv.notify_one();
    return;
  }
  ++free_;
}

int ConcurrencyLimiter::busy() const {
  std::lock_guard lock(mutex_);
  return slots_ - free_;
}

std::size_t ConcurrencyLimiter::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

}  // namespace strata::server
