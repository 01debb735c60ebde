#include "common/call_control.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace strata::server {

using SteadyClock = std::chrono::steady_clock;

ServiceError DeadlineLeavesNoTime(double left_s) {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "the call's deadline leaves %.3f s, too little to plan: allow more time (set "
                "a later deadline)",
                std::max(0.0, left_s));
  return MakeError(ErrorCode::kDeadlineExceeded, buf);
}

double CallControl::LeftSeconds() const {
  if (deadline == SteadyClock::time_point::max()) return std::numeric_limits<double>::infinity();
  return std::chrono::duration<double>(deadline - SteadyClock::now()).count();
}

double WorkSecondsLeft(double left_s) {
  if (!std::isfinite(left_s)) return left_s;
  return left_s - std::min(0.1 * std::max(left_s, 0.0), 0.1);
}

}  // namespace strata::server
