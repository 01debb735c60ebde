#include "later_departures.hpp"

#include <array>
#include <optional>
#include <utility>

#include "hold_schedule.hpp"
#include "parked_robots.hpp"
#include "strata/fleet/motion_conflict.hpp"

namespace strata::fleet_internal {
namespace {

// The later departures tried [s after the request's]. The plans made for a later departure
// meet the others elsewhere, and so add other stops, search another route or replan other
// robots: on fleet_benchmark most of the requests refused at the departure fitted 5 or 10 s
// later, and 20 and 30 s planned most of the rest (garage, 50 robots: 97.7-98.2% of the
// requests planned with 5 and 10 s, 99.4-99.7% with all four). Only requests refused at every
// earlier try reach the later ones, so the plan p95 stayed as it was on most runs; a request
// they all refuse costs the more (up to 6 s on fleet_benchmark). In commit order the tries
// doubled that p95 at 50 robots for a few more tasks planned, so only a request that may
// replan others tries them (docs/design.md, "Fleets", step 8).
constexpr std::array kLaterDeparturesS = {5.0, 10.0, 20.0, 30.0};

/// `later`, planned for a departure `held_s` after `request`'s, with the robot holding at its
/// start from `request`'s departure until then: the hold joins a wait `later` begins with.
/// None when the hold meets another robot (checked exactly against the others' committed
/// motions, which every robot follows until then: those `later` replans take their new ones
/// from a notice after its departure).
std::optional<FleetPlanResult> HeldAtStart(FleetPlanResult later, double held_s,
                                           const FleetPlanRequest& request) {
  Trajectory& trajectory = later.plan.trajectory;
  if (FirstTrafficConflict(Standing(trajectory.Position(0), trajectory.dimension, later.motion.body,
                                    request.departure_ns, later.motion.start_ns),
                           request.others, request.fleet.rule)) {
    return std::nullopt;
  }
  const bool waits_at_start = !later.holds.empty() && later.holds.front().start_s == 0;
  for (std::size_t k = waits_at_start ? 1 : 0; k < later.holds.size(); ++k) {
    later.holds[k].start_s += held_s;
  }
  if (waits_at_start) {
    trajectory.pieces.front().duration_s += held_s;
    later.holds.front().duration_s += held_s;
  } else {
    trajectory.pieces.insert(trajectory.pieces.begin(), RestAtStart(trajectory, held_s));
    later.holds.insert(later.holds.begin(), FleetHold{0, held_s, trajectory.Position(0).head<3>()});
    ++later.plan.stats.pieces;
  }
  later.plan.stats.duration_s += held_s;
  for (double& via_s : later.plan.via_times_s) via_s += held_s;
  later.wait_s += held_s;
  later.arrival_s += held_s;
  // The same motion from the request's departure on: its body, rule and end (its arrival and
  // the lease) stay as they were.
  later.motion.start_ns = request.departure_ns;
  later.motion.trajectory = trajectory;
  return later;
}

}  // namespace

Expected<FleetPlanResult> PlanLeavingLater(const FleetPlanRequest& request, Error refusal,
                                           LegCache* legs, const DeparturePlanner& plan_at) {
  const RobotState& start = request.plan.start;
  if (refusal.code != ErrorCode::kReservationConflict || request.fleet.replan.max_robots == 0 ||
      !start.velocity_mps.isZero() || !start.acceleration_mps2.isZero()) {
    return refusal;
  }
  for (const double held_s : kLaterDeparturesS) {
    if (held_s > request.fleet.max_wait_s) break;
    FleetPlanRequest later = request;
    later.departure_ns = AddSeconds(request.departure_ns, held_s);
    later.fleet.max_wait_s -= held_s;
    Expected<FleetPlanResult> again = plan_at(later, legs);
    if (again) {
      std::optional<FleetPlanResult> held = HeldAtStart(std::move(again).value(), held_s, request);
      // A robot passes the start meanwhile: holding there longer meets it too.
      if (!held) break;
      return std::move(*held);
    }
    // Out of time: the refusal at the departure stands.
    if (again.error().code == ErrorCode::kCancelled ||
        again.error().code == ErrorCode::kDeadlineExceeded) {
      break;
    }
  }
  // The refusal at the departure names what is in the way now.
  return refusal;
}

}  // namespace strata::fleet_internal
