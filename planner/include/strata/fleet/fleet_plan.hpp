#pragma once
/// Planning one robot of a fleet against the motions the others have committed (priority by
/// commit order: the robot planned later keeps out of the way of those planned before).
///
/// How (docs/design.md, "Fleets"): other robots parked for the time this plan may take are
/// keep-out zones, which the search and the optimiser go around; the plan is then placed at
/// its departure, and the robot waits, at rest, at its start and at stops along its route for
/// the moving ones to pass (a search over the departures from each stop, hold_schedule.hpp),
/// each departure checked exactly against every motion (traffic.hpp). Where no waits clear
/// the route, a route is searched in space and time over the graph (SIPP: waiting before a
/// lane, pulling into a bay, taking another aisle) and the plan follows it; where waits still
/// do not clear it, a stop is added before what it meets, out of that robot's way, and the
/// route is planned again through it. The trajectory returned is Plan's verified one with the waits
/// inserted as pieces at rest at verified points, checked exactly against every motion. Where
/// nothing clears a robot still on its way, and that robot follows new trajectories it is sent,
/// it may be planned again to let this one pass first (ReplanOptions); then, where nothing fits
/// at the departure, the robot holds at its start a few seconds (within max_wait_s) and is
/// planned as above from then.
#include <cstdint>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/fleet/motion_conflict.hpp"
#include "strata/fleet/traffic.hpp"
#include "strata/planner.hpp"
#include "strata/status.hpp"

namespace strata {

/// Replanning robots in the way: when the plan is refused for a robot that is still on its way
/// (FleetPlanRequest::replannable says which may be), this robot is planned first, against
/// that robot's motion up to a little after `notice_s` from the departure, and that robot is
/// then planned again from where it is at notice_s, to its goal, among the others and this
/// plan. Repeated for the next robot the plan is then refused for, up to max_robots; all of
/// them plan, or nothing changes and the first refusal stands. A request that may replan
/// others, refused so at its departure, is also planned a few seconds later, the robot holding
/// at its start until then (PlanAmongTraffic): more plans per request, fewer refusals.
inline constexpr int kMaxReplannedRobots = 3;    ///< ReplanOptions::max_robots's bound.
inline constexpr double kMaxReplanNoticeS = 10;  ///< ReplanOptions::notice_s's bound [s].

struct ReplanOptions {
  /// Robots replanned for one plan at most, in [0, kMaxReplannedRobots]; 0 (the default)
  /// replans none.
  int max_robots = 0;
  /// From the departure until a replanned robot takes its new trajectory [s], in
  /// [0, kMaxReplanNoticeS]: the time it takes to hear of it.
  double notice_s = 1.0;
  /// Longest a replanned robot may wait, in all [s], in [0, 3600].
  double max_wait_s = 60;
  Status Validate(std::string_view path) const;
};

struct FleetPlanOptions {
  SeparationRule rule;
  /// Longest the robot may wait for others to pass, at its start and at stops on its way
  /// together [s], in [0, 3600].
  double max_wait_s = 60;
  ReplanOptions replan;
  Status Validate(std::string_view path) const;
};

/// One of the others that may be replanned (ReplanOptions): a robot that follows a new
/// trajectory sent to it, with a 3-D trajectory (one of dimension 4 is never replanned).
struct ReplannableRobot {
  std::size_t other = 0;  ///< Its index in FleetPlanRequest::others.
  RobotProfile profile;   ///< Its robot's profile, to plan it with.
};

struct FleetPlanRequest {
  PlanRequest plan;  ///< As for a robot alone on the site.
  /// Absolute time at which the robot is at plan.start and may leave [ns].
  std::int64_t departure_ns = 0;
  /// Until when the robot then stays parked at its goal [ns] (its reservation's lease); the
  /// arrival, if later, takes its place.
  std::int64_t parked_until_ns = 0;
  FleetPlanOptions fleet;
  /// The other robots' committed motions (not this robot's own earlier one).
  std::span<const ReservedMotion> others;
  /// Those of `others` that may be replanned (ReplanOptions), each at most once.
  std::span<const ReplannableRobot> replannable;
};

/// A wait in a fleet plan: a piece of the trajectory at rest.
struct FleetHold {
  double start_s = 0;     ///< When it begins, from the trajectory's start [s].
  double duration_s = 0;  ///< [s], > 0.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< Where the robot stands [m].
};

/// A robot planned again to let this one pass first (ReplanOptions).
struct ReplannedRobot {
  std::size_t other = 0;  ///< Its index in FleetPlanRequest::others.
  /// Its new motion from the notice on (its committed one is followed until then:
  /// ContinuedBy), to the same goal, parked there until its motion's end_ns as before. It
  /// begins at the committed motion's point, velocity and acceleration then, but for the
  /// height, which Plan takes from the ground under it (within centimetres).
  FleetMotion motion;
  double wait_s = 0;  ///< How long it waits in its new motion, in all [s].
};

struct FleetPlanResult {
  /// The plan; each of `holds` is a piece at rest in its trajectory, and its duration and via
  /// times include them. Its `via` and via times are the request's vias only.
  PlanResult plan;
  FleetMotion motion;            ///< The trajectory at its departure, parked until parked_until_ns.
  double wait_s = 0;             ///< How long the robot waits in all, the sum of `holds` [s].
  std::vector<FleetHold> holds;  ///< In trajectory order; at the start when start_s is 0.
  int stops_added = 0;           ///< Stops on the way added so that the robot could wait.
  int parked_robots_avoided = 0;  ///< Others' parking places planned around as zones.
  int departures_checked = 0;     ///< Departures checked against the traffic.
  /// Times the route was planned: the first, and one more each time robots parked in its way
  /// were found, a route was searched in space and time, or a stop was added (at most 6).
  int plan_rounds = 0;
  /// When the trajectory first reaches the goal, from its start [s]: its duration, or less
  /// when the robot then makes way.
  double arrival_s = 0;
  /// The robot makes way at its goal for a robot that passes there later: after arriving it
  /// holds there, leaves for a place beside the goal, holds there and comes back (the last
  /// two of `holds` and the pieces between them).
  bool makes_way = false;
  /// Robots planned again to let this one pass first, in the order they were planned; each
  /// new motion keeps clear of this plan's, of the others and of those replanned before it.
  std::vector<ReplannedRobot> replanned;
};

/// Plans `request` among the others' motions. Fails as Plan does, and with
/// kReservationConflict naming the robot in the way, when and where: the start is already
/// within reach of a robot parked there, the goal is where another robot stays parked, or no
/// waits up to max_wait_s in all clear every motion (and replanning the robots in the way,
/// when allowed, did not clear it either, at the departure nor, then, a few seconds after it
/// with the robot holding at its start until then). `should_stop` as for Plan.
Expected<FleetPlanResult> PlanAmongTraffic(const PlanningMap& map, const FleetPlanRequest& request,
                                           const std::function<bool()>& should_stop = {});

}  // namespace strata
