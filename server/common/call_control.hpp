#pragma once
/// What a call brings to the work it asks for, whichever API it came through: when its client
/// stops waiting, and whether it has gone. No gRPC here (rpc/rpc_boundary.hpp makes one of a
/// gRPC call).
#include <chrono>
#include <functional>
#include <string>

#include "common/service_error.hpp"

namespace strata::server {

/// What a call brings to the work it asks for: when its client stops waiting, and whether it
/// has gone.
struct CallControl {
  /// The call's deadline; max() for none.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  /// Returns true once the client has cancelled the call; may be empty.
  std::function<bool()> cancelled;
  /// The call's credentials ("Bearer TOKEN", the "authorization" metadata or header), empty
  /// without: who owns what the call commits (a robot's reservation).
  std::string authorization;

  /// Seconds left before the deadline (negative once past); +infinity without one.
  double LeftSeconds() const;
};

/// How much sooner a client's deadline may pass than the server's copy of it [s]: the server
/// counts the time left from when the call arrived, which on a loaded machine is milliseconds
/// after the client sent it. A call cancelled that close to its deadline ran out of time.
inline constexpr double kClientDeadlineLeadS = 0.05;

/// The latest a call may work before answering: its deadline less a margin to send the answer
/// (10% of the time left, at most 0.1 s). `left_s` as CallControl::LeftSeconds.
double WorkSecondsLeft(double left_s);

/// kDeadlineExceeded: a deadline that leaves `left_s` [s] is too close to plan.
ServiceError DeadlineLeavesNoTime(double left_s);

}  // namespace strata::server
