#pragma once
/// The planning slots every call that plans shares, whichever API it came through (gRPC Plan,
/// each item of PlanBatch, EstimateCosts, GetMapGeometry with a robot, the web viewer's JSON
/// API): --max-concurrent-plans run at once, --max-queued-plans wait for one, first come first
/// served, each until its call's deadline (or --max-plan-time-s for a call without one). A call
/// holding a slot may borrow idle ones besides (EstimateCosts' searches), never one a queued
/// call is owed. No gRPC here: a call describes its deadline and cancellation with a
/// CallControl.
#include <atomic>
#include <chrono>
#include <functional>
#include <limits>

#include "common/call_control.hpp"
#include "common/service_error.hpp"
#include "rpc/concurrency_limiter.hpp"

namespace strata::server {

class PlanningSlots {
 public:
  /// `slots` >= 1 run at once, `max_queued` >= 0 wait; `max_plan_time_s` > 0 caps the time
  /// a call without a deadline waits (and every plan's budget, which the caller applies).
  PlanningSlots(int slots, int max_queued, double max_plan_time_s);

  /// Work done holding a slot: `should_stop` is true once the call is cancelled or Stop was
  /// called; `queue_s` is how long the call waited for its slot [s].
  using Work =
      std::function<ServiceStatus(const std::function<bool()>& should_stop, double queue_s)>;

  /// Waits for a slot and runs `work` in it. Fails without running it with kDeadlineExceeded
  /// (the deadline leaves no time), kServerBusy (the queue is full, or the slot did not come
  /// before the deadline), kCancelled (the client cancelled while queued). Whatever fails as
  /// cancelled after Stop fails with kShuttingDown instead.
  ServiceStatus Run(const CallControl& call, const Work& work);

  /// Takes an idle slot for more work of a call that already holds one (Run's `work`), only
  /// when a slot is free, that is when no call waits: a borrowed slot never takes a turn owed
  /// to a queued call. True when taken: hold it with a BorrowedSlot, and give it back as soon
  /// as CallsWaiting().
  bool TryBorrow() { return limiter_.TryAcquire(); }
  /// True while some call waits for a slot.
  bool CallsWaiting() const { return limiter_.queued() > 0; }

  /// Holds a slot TryBorrow took, for a scope.
  class BorrowedSlot {
   public:
    explicit BorrowedSlot(PlanningSlots* slots) : slot_(&slots->limiter_) {}

   private:
    ConcurrencyLimiter::Slot slot_;
  };

  /// Stops every call running or queued now and later: they answer SHUTTING_DOWN (the end of
  /// the shutdown grace). Thread-safe.
  void Stop() { stopping_ = true; }
  /// `outcome` as the call should answer it: a cancellation after Stop (the planner and the
  /// queue report it as cancelled) as SHUTTING_DOWN, anything else as it is. Run applies it;
  /// work that spans several Runs (PlanBatch) applies it to its own outcome.
  ServiceStatus ExplainStop(ServiceStatus outcome) const;

  double max_plan_time_s() const { return max_plan_time_s_; }
  int slots() const { return limiter_.slots(); }
  /// Slots running work now, and calls waiting for one (metrics: what an autoscaler reads).
  int busy() const { return limiter_.busy(); }
  std::size_t queued() const { return limiter_.queued(); }

 private:
  ConcurrencyLimiter limiter_;
  const double max_plan_time_s_;
  std::atomic<bool> stopping_ = false;
};

}  // namespace strata::server
