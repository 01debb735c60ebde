#pragma once
/// Seconds on the steady clock since a moment, as every stage time and log line reports them.
#include <chrono>

namespace strata::common {

/// Seconds elapsed on the steady clock since `start` [s].
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace strata::common
