#include "concurrency_limiter.hpp"

#include <algorithm>

namespace strata::server {

bool ConcurrencyLimiter::Acquire(std::chrono::steady_clock::time_point deadline,
                                 const std::function<bool()>& should_stop) {
  // The caller's cancellation has no notification; poll it.
  constexpr auto kPollPeriod = std::chrono::milliseconds(50);
  std::unique_lock lock(mutex_);
  while (free_ == 0) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline || (should_stop && should_stop())) return false;
    released_.wait_until(lock, std::min(deadline, now + kPollPeriod));
  }
  --free_;
  return true;
}

void ConcurrencyLimiter::Release() {
  {
    std::lock_guard lock(mutex_);
    ++free_;
  }
  released_.notify_one();
}

}  // namespace strata::server
