#include "replan_in_the_way.hpp"

#include <algorithm>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace strata::fleet_internal {
namespace {

// A replanned robot's committed motion stays in the way of the plan that goes first until
// this long after the notice [s]: moving at the notice, the robot needs room to slow down or
// turn off before it meets that plan (its new motion is then checked against it exactly).
// Not tuned: 1 and 3 s planned as many of fleet_benchmark's tasks (garage, 50 robots, seeds
// 1-3: 91.3-96.3% and 93.9-96.3% against 93.3-96.3%; docs/design.md, "Fleets").
constexpr double kReplanLeadS = 2.0;
// A new motion begins where the committed one is at the notice: in x, y within kJoinM [m]
// and in velocity and acceleration within kJoinMotion [m/s, m/s^2]; in height within
// kHeightJoinM [m], since Plan puts its start on the ground under it, where a trajectory
// through the dead band of the ground's penalty may run centimetres above or below.
constexpr double kJoinM = 1e-6;
constexpr double kJoinMotion = 1e-6;
constexpr double kHeightJoinM = 0.1;
// Names the robot being planned in the requests of the robots replanned behind it.
constexpr const char* kPlannedFirst = "(the robot that goes first)";

/// `motion` until `until_ns`: cut there (gone after it), or as it is when it ends by then.
FleetMotion Until(const FleetMotion& motion, std::int64_t until_ns) {
  FleetMotion cut = motion;
  if (until_ns >= motion.ArrivalNs()) {
    cut.end_ns = std::max(motion.ArrivalNs(), std::min(motion.end_ns, until_ns));
    return cut;
  }
  const double until_s = SecondsBetween(motion.start_ns, until_ns);
  cut.trajectory.pieces.clear();
  double piece_start_s = 0;
  for (const TrajectoryPiece& piece : motion.trajectory.pieces) {
    if (piece_start_s >= until_s) break;
    cut.trajectory.pieces.push_back(piece);
    cut.trajectory.pieces.back().duration_s = std::min(piece.duration_s, until_s - piece_start_s);
    piece_start_s += piece.duration_s;
  }
  cut.end_ns = cut.ArrivalNs();
  return cut;
}

/// The robot `refusal` names, when `request` may replan it at `notice_ns`: one of
/// request.replannable, not already `replanning`, with a 3-D trajectory that has begun by then
/// and not yet arrived. Null otherwise.
const ReplannableRobot* InTheWay(const FleetPlanRequest& request, const Error& refusal,
                                 std::int64_t notice_ns,
                                 const std::vector<const ReplannableRobot*>& replanning) {
  if (refusal.code != ErrorCode::kReservationConflict) return nullptr;
  const auto named = refusal.details.find("robot_id");
  if (named == refusal.details.end()) return nullptr;
  for (const ReplannableRobot& robot : request.replannable) {
    const ReservedMotion& other = request.others[robot.other];
    if (other.robot_id != named->second) continue;
    const FleetMotion& motion = other.motion;
    const bool on_its_way = motion.start_ns <= notice_ns && notice_ns < motion.ArrivalNs();
    const bool again = std::find(replanning.begin(), replanning.end(), &robot) != replanning.end();
    if (on_its_way && !again && motion.trajectory.dimension == 3) return &robot;
  }
  return nullptr;
}

bool Stopped(const Error& error) {
  return error.code == ErrorCode::kCancelled || error.code == ErrorCode::kDeadlineExceeded;
}

/// Whether `next` begins where `committed` is at `notice_ns` (kJoinM, kJoinMotion,
/// kHeightJoinM).
bool Joins(const FleetMotion& committed, const Trajectory& next, std::int64_t notice_ns) {
  const double t = committed.TrajectoryTimeAt(notice_ns);
  const StateVector at = committed.trajectory.Position(t);
  const StateVector from = next.Position(0);
  return (from.head<2>() - at.head<2>()).norm() <= kJoinM &&
         std::abs(from.z() - at.z()) <= kHeightJoinM &&
         (next.Velocity(0) - committed.trajectory.Velocity(t)).norm() <= kJoinMotion &&
         (next.Acceleration(0) - committed.trajectory.Acceleration(t)).norm() <= kJoinMotion;
}

}  // namespace

Expected<FleetPlanResult> PlanReplanningOthers(const FleetPlanRequest& request, Error refusal,
                                               LegCache* legs,
                                               const CommitOrderPlanner& plan_in_order) {
  const ReplanOptions& options = request.fleet.replan;
  const std::int64_t notice_ns = AddSeconds(request.departure_ns, options.notice_s);
  const std::int64_t lead_ns = AddSeconds(notice_ns, kReplanLeadS);
  // The others as the robot that goes first plans against them: those replanned are in its
  // way only until the lead after the notice.
  std::vector<ReservedMotion> others(request.others.begin(), request.others.end());
  std::vector<const ReplannableRobot*> replanning;
  std::optional<FleetPlanResult> first;
  const Error* refused = &refusal;
  Error refused_again;
  while (!first) {
    const ReplannableRobot* robot = InTheWay(request, *refused, notice_ns, replanning);
    if (robot == nullptr || static_cast<int>(replanning.size()) >= options.max_robots) {
      return refusal;
    }
    replanning.push_back(robot);
    others[robot->other].motion = Until(request.others[robot->other].motion, lead_ns);
    FleetPlanRequest going_first = request;
    going_first.others = others;
    going_first.replannable = {};
    Expected<FleetPlanResult> planned = plan_in_order(going_first, legs);
    if (planned) {
      first = std::move(planned).value();
    } else if (Stopped(planned.error())) {
      return std::move(planned).error();
    } else {
      refused_again = std::move(planned).error();
      refused = &refused_again;
    }
  }

  // Each robot in the way, planned again from the notice behind the one that goes first and
  // those replanned before it, and ahead of those replanned after it (still cut at the lead).
  others.push_back({kPlannedFirst, first->motion});
  for (const ReplannableRobot* robot : replanning) {
    const FleetMotion& committed = request.others[robot->other].motion;
    const double t = committed.TrajectoryTimeAt(notice_ns);
    FleetPlanRequest again;
    again.plan.start.position_m = committed.trajectory.Position(t).head<3>();
    again.plan.start.velocity_mps = committed.trajectory.Velocity(t).head<3>();
    again.plan.start.acceleration_mps2 = committed.trajectory.Acceleration(t).head<3>();
    again.plan.goal.position_m =
        committed.trajectory.Position(committed.trajectory.TotalDuration()).head<3>();
    again.plan.profile = robot->profile;
    again.plan.options = request.plan.options;
    again.departure_ns = notice_ns;
    again.parked_until_ns = committed.end_ns;
    again.fleet.rule = request.fleet.rule;
    // It keeps asking what it asked (the pair's separation is the larger of the two's).
    again.fleet.rule.separation_m = committed.separation_m;
    again.fleet.max_wait_s = options.max_wait_s;
    std::vector<ReservedMotion> around;
    around.reserve(others.size() - 1);
    for (std::size_t i = 0; i < others.size(); ++i) {
      if (i != robot->other) around.push_back(others[i]);
    }
    again.others = around;
    Expected<FleetPlanResult> replanned = plan_in_order(again, nullptr);
    if (!replanned) {
      if (Stopped(replanned.error())) return std::move(replanned).error();
      return refusal;
    }
    if (!Joins(committed, replanned.value().plan.trajectory, notice_ns)) return refusal;
    others[robot->other].motion = replanned.value().motion;
    first->replanned.push_back({robot->other, replanned.value().motion, replanned.value().wait_s});
  }
  return std::move(first).value();
}

}  // namespace strata::fleet_internal
