#pragma once
/// When a robot whose route is planned in legs (from rest to rest, joined at stops) waits at
/// its start and at each stop so that it meets none of the other robots' motions: a search
/// over the times at which it leaves each stop, in the spirit of SIPP (safe intervals) along
/// one route. The route's shape is fixed; only the waits change.
///
/// At each stop the robot may hold from its arrival until the first moment holding there
/// would meet another robot (the end of its safe interval); it tries to leave at the arrival,
/// then after waits of a ladder (0.5 s steps, growing by a quarter), each departure checked
/// exactly against every motion, earliest first, with backtracking. An arrival at a stop
/// inside the safe interval of an earlier arrival that led nowhere is not searched again (the
/// earlier one could have waited for it). The waits add up to at most the budget.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>
#include <vector>

#include "strata/fleet/traffic.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata::fleet_internal {

/// The waits that clear every motion: waits_s[i] before leg i, at its first point.
struct HoldSchedule {
  std::vector<double> waits_s;
  int departures_checked = 0;
};

/// What kept the search from a schedule: the last leg it reached, and what that leg met on the
/// departure that got furthest along it (no conflict when it met nothing but the stop's hold
/// or the budget ended the search).
struct HoldFailure {
  std::size_t leg = 0;
  std::int64_t departure_ns = 0;  ///< When that leg left [ns].
  std::optional<TrafficConflict> conflict;
  int departures_checked = 0;
};

/// Legs after the arrival, when the robot makes way at its goal for another that passes
/// (fleet_plan.cpp): it leaves the goal for a place beside it and comes back. The waits before
/// them are parked time, not waiting on the way: none counts against the route's budget. The
/// robot leaves the goal as late as it can.
struct ParkedLegs {
  std::size_t first = 0;   ///< The index of the leg leaving the goal; the legs after it follow.
  double max_hold_s = 0;   ///< Longest wait at the goal, before leg `first` [s].
  double max_aside_s = 0;  ///< Longest wait before each later leg [s].
};

/// The waits at the start (when `may_wait_at_start`; a robot already moving cannot) and at
/// each stop between `legs` that keep the route clear of `traffic.others`, the last leg
/// parked until traffic.parked_until_ns, with at most `max_wait_s` [s] of waiting in all
/// (beside `parked`'s, if any) and at most `max_departures` departures checked.
std::variant<HoldSchedule, HoldFailure> ScheduleHolds(std::span<const Trajectory> legs,
                                                      bool may_wait_at_start,
                                                      const Traffic& traffic, double max_wait_s,
                                                      int max_departures,
                                                      std::optional<ParkedLegs> parked = {});

/// The waits tried at a stop, shortest first: 0, half-second steps, then growing by a quarter,
/// up to and including `max_wait_s`.
std::vector<double> WaitLadder(double max_wait_s);

/// The waits tried before leaving the goal to make way, longest first: `hold_s` (the most the
/// robot may stand there) less the ladder's steps (WaitLadder's from half a second on), then 0.
std::vector<double> WaitLadderBackFrom(double hold_s);

/// A piece of `duration_s` at rest at `trajectory`'s first point (same dimension).
TrajectoryPiece RestAtStart(const Trajectory& trajectory, double duration_s);

}  // namespace strata::fleet_internal
