#include "rpc/planning_slots.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include <fmt/format.h>

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

SteadyClock::time_point After(double seconds) {
  return SteadyClock::now() +
         std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(seconds));
}

}  // namespace

PlanningSlots::PlanningSlots(int slots, int max_queued, double max_plan_time_s)
    : limiter_(slots, max_queued), max_plan_time_s_(max_plan_time_s) {}

ServiceStatus PlanningSlots::Run(const CallControl& call, const Work& work) {
  const auto should_stop = [this, &call] {
    return stopping_ || (call.cancelled && call.cancelled());
  };
  auto outcome = [&]() -> ServiceStatus {
    const double left_s = call.LeftSeconds();
    if (left_s <= 0) return DeadlineLeavesNoTime(left_s);
    const auto queue_start = SteadyClock::now();
    // A call waits for its slot until its own deadline (less the margin to answer); one
    // without a deadline, at most --max-plan-time-s.
    const bool has_deadline = std::isfinite(left_s);
    const auto queue_deadline = After(has_deadline ? WorkSecondsLeft(left_s) : max_plan_time_s_);
    switch (limiter_.Acquire(queue_deadline, should_stop)) {
      case ConcurrencyLimiter::Admission::kAdmitted: break;
      case ConcurrencyLimiter::Admission::kStopped:
        return MakeError(ErrorCode::kCancelled,
                         "the client cancelled the call while it was queued");
      case ConcurrencyLimiter::Admission::kQueueFull:
        return MakeError(ServiceErrorCode::kServerBusy,
                         fmt::format("all {} planning slots are busy and {} calls already wait "
                                     "(--max-queued-plans): retry with backoff",
                                     limiter_.slots(), limiter_.max_queued()));
      case ConcurrencyLimiter::Admission::kTimedOut:
        return MakeError(
            ServiceErrorCode::kServerBusy,
            fmt::format("all {} planning slots stayed busy until {}", limiter_.slots(),
                        has_deadline ? "the call's deadline: retry with backoff, or allow a "
                                       "later deadline"
                                     : "--max-plan-time-s had passed (the call set no "
                                       "deadline): retry with backoff, or set a deadline"));
    }
    ConcurrencyLimiter::Slot slot(&limiter_);
    const double queue_s = std::chrono::duration<double>(SteadyClock::now() - queue_start).count();
    return work(should_stop, queue_s);
  }();
  return ExplainStop(std::move(outcome));
}

ServiceStatus PlanningSlots::ExplainStop(ServiceStatus outcome) const {
  if (!outcome.ok() && stopping_ &&
      outcome.error().code == ServiceError::Code(ErrorCode::kCancelled)) {
    return MakeError(ServiceErrorCode::kShuttingDown,
                     "the server is shutting down and its grace (--shutdown-grace-s) ran "
                     "out before the call finished: call again (another replica answers)");
  }
  return outcome;
}

}  // namespace strata::server
