#include "common/call_control.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace strata::server {

using SteadyClock = std::chrono::steady_clock;

ServiceError DeadlineLeavesNoTime(double left_s) {
  return MakeError(ErrorCode::kDeadlineExceeded,
                   fmt::format("the call's deadline leaves {:.3f} s, too little to plan: allow "
                               "more time (set a later deadline)",
                               std::max(0.0, left_s)));
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
