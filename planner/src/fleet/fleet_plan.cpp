#include "strata/fleet/fleet_plan.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "hold_schedule.hpp"
#include "later_departures.hpp"
#include "parked_robots.hpp"
#include "replan_in_the_way.hpp"
#include "route_guides.hpp"
#include "space_time_search.hpp"
#include "stop_places.hpp"

namespace strata {
namespace {

using fleet_internal::AddedStop;
using fleet_internal::kMinStopSpacingM;
using fleet_internal::ParkedInTheWay;
using fleet_internal::ParkedInWay;
using fleet_internal::ParkedZone;
using fleet_internal::Standing;
using fleet_internal::StandingPoint;
using fleet_internal::StopBefore;

// Plans made for one request at most: the first, and one more each time robots parked in the
// way are found (all that the trajectory meets at once), a route is searched in space and
// time, or a stop is added.
constexpr int kMaxPlanRounds = 6;
// Stops added to one route at most (each makes a leg planned of its own), within kMaxVias
// together with the request's vias.
constexpr int kMaxAddedStops = 3;
// Departures checked against the traffic per route at most (each an exact check of a leg
// against every motion).
constexpr int kMaxDeparturesChecked = 200;
// Longer than any trip a robot makes on a site [s]: a robot parked from the departure until
// max_wait_s plus this after it is in the way of no plan's passage but as a standing body.
constexpr double kLongestTripS = 600;
// A leg planned to make way at the goal starts where the route ended within kLegJoinM [m],
// and ends at the goal (or the place beside it) within kLegEndM [m].
constexpr double kLegJoinM = 1e-9;
constexpr double kLegEndM = 1e-6;
// A robot making way at its goal waits beside it this long at most [s]: a robot passes by in
// seconds; one that stays is not waited out.
constexpr double kMakeWayAsideS = 60;
// A space-time route keeps its nodes the search's margin (0.25 m) beyond the limit from a robot
// while it stands parked; a trajectory through the route's guides cuts up to a metre closer.
// Robots parked within this much beyond the limit of the route's way are planned around from
// the plan through it on (tuned on fleet_benchmark: docs/design.md, "Fleets").
constexpr double kParkedOnWayReachM = 0.4;
// Rounds of one request that try making way at the goal at most (each plans two short legs and
// searches the waits again).
constexpr int kMaxMakeWayRounds = 2;

/// A point the route passes through: one of the request's vias, or one added (a stop to wait
/// at, or a point of a space-time route).
struct RoutePoint {
  Via via;
  bool added = false;
};

bool StartsAtRest(const Trajectory& trajectory) {
  return trajectory.EvaluatePiece(0, 0, 1).isZero(1e-9) &&
         trajectory.EvaluatePiece(0, 0, 2).isZero(1e-9);
}

/// The traffic `request`'s robot is planned among: its departure, lease, body and the others.
Traffic TrafficOf(const FleetPlanRequest& request) {
  Traffic traffic;
  traffic.departure_ns = request.departure_ns;
  traffic.parked_until_ns = request.parked_until_ns;
  traffic.body = FleetBody::FromProfile(request.plan.profile);
  traffic.rule = request.fleet.rule;
  traffic.others = request.others;
  return traffic;
}

/// The index of the piece that begins at `time_s` into `trajectory` (its nearest boundary).
std::size_t PieceStartingAt(const Trajectory& trajectory, double time_s) {
  std::size_t best = 0;
  double start_s = 0;
  double best_gap = time_s;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    start_s += trajectory.pieces[i].duration_s;
    if (std::abs(start_s - time_s) < best_gap) {
      best_gap = std::abs(start_s - time_s);
      best = i + 1;
    }
  }
  return best;
}

/// `plan`'s trajectory cut into its legs at the route's stops (Plan ends a leg at each).
std::vector<Trajectory> SplitAtStops(const PlanResult& plan, const std::vector<RoutePoint>& route) {
  std::vector<std::size_t> cuts = {0};
  for (std::size_t j = 0; j < route.size(); ++j) {
    if (route[j].via.stop) cuts.push_back(PieceStartingAt(plan.trajectory, plan.via_times_s[j]));
  }
  cuts.push_back(plan.trajectory.pieces.size());
  std::vector<Trajectory> legs;
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    Trajectory leg;
    leg.dimension = plan.trajectory.dimension;
    leg.pieces.assign(plan.trajectory.pieces.begin() + static_cast<std::ptrdiff_t>(cuts[k]),
                      plan.trajectory.pieces.begin() + static_cast<std::ptrdiff_t>(cuts[k + 1]));
    legs.push_back(std::move(leg));
  }
  return legs;
}

std::string TimeText(std::int64_t from_ns, std::int64_t time_ns) {
  return fmt::format("{:.2f} s after the departure", SecondsBetween(from_ns, time_ns));
}

/// What a plan stopped by its caller answers: kCancelled, saying at which `step`.
Error CancelledWhile(std::string_view step) {
  return Error{ErrorCode::kCancelled, fmt::format("the plan was cancelled while {}", step)};
}

Error ParkedOnEnd(const ReservedMotion& other, const FleetPlanRequest& request,
                  std::string_view end) {
  const Eigen::Vector3d at = other.motion.ReferencePointAt(other.motion.end_ns);
  Error error{ErrorCode::kReservationConflict,
              fmt::format("the {} is where robot {} stays parked, at ({:.2f}, {:.2f}, {:.2f}) m "
                          "until {}: plan to another {} or wait until that reservation ends",
                          end, internal::Quote(other.robot_id), at.x(), at.y(), at.z(),
                          TimeText(request.departure_ns, other.motion.end_ns), end),
              std::string(end == "goal" ? "goal.position_m" : "start.position_m")};
  error.details = {{"robot_id", other.robot_id}, {"time_ns", std::to_string(other.motion.end_ns)}};
  return error;
}

/// The latest a plan through `plain` (its trajectory `plain_s` long) may arrive at its goal,
/// after the departure [s]: the space-time search's horizon, past every wait and detour it
/// tries, and the stops' waits on the plain route.
double LatestArrivalS(double max_wait_s, double plain_s) { return max_wait_s + 2 * plain_s + 10; }

/// The first meeting of this robot, standing at the end of `plain` from `latest_s` after the
/// departure (the latest arrival any of its plans may have, LatestArrivalS) until it is
/// parked no more, with another robot: then every plan ends in that meeting, and none is
/// worth trying. None when it stays clear of them all (checked exactly), or leaves its goal
/// before that arrival.
std::optional<TrafficConflict> GoalTakenLater(const Trajectory& plain, const Traffic& traffic,
                                              double latest_s) {
  const std::int64_t latest_ns = AddSeconds(traffic.departure_ns, latest_s);
  if (traffic.parked_until_ns <= latest_ns) return std::nullopt;
  return FirstTrafficConflict(Standing(plain.Position(plain.TotalDuration()), plain.dimension,
                                       traffic.body, latest_ns, traffic.parked_until_ns),
                              traffic.others, traffic.rule);
}

Error GoalTaken(const TrafficConflict& met, const FleetPlanRequest& request, double latest_s) {
  const ReservedMotion& other = request.others[met.other];
  const MotionConflict& c = met.conflict;
  Error error{ErrorCode::kReservationConflict,
              fmt::format("the goal is not free for good: robot {} comes within {:.3f} m of it "
                          "(the limit is {:.3f} m) at ({:.2f}, {:.2f}, {:.2f}) m, {}, when this "
                          "robot would stand there (every plan arrives within {:.1f} s, and the "
                          "robot stays parked until {}): plan to another goal, or leave after "
                          "that robot has passed",
                          internal::Quote(other.robot_id), c.horizontal_distance_m, c.limit_m,
                          c.point_b.x(), c.point_b.y(), c.point_b.z(),
                          TimeText(request.departure_ns, c.time_ns), latest_s,
                          TimeText(request.departure_ns, request.parked_until_ns)),
              "goal.position_m"};
  error.details = ConflictDetails(other.robot_id, c);
  return error;
}

/// `route` with a stop at `position`, which `plan` (planned through `route`) passes at
/// `time_s`, put in its order among the route's points.
void InsertStop(std::vector<RoutePoint>& route, const PlanResult& plan, double time_s,
                const Eigen::Vector3d& position) {
  std::size_t at = 0;
  while (at < route.size() && plan.via_times_s[at] <= time_s) ++at;
  route.insert(route.begin() + static_cast<std::ptrdiff_t>(at),
               RoutePoint{Via{position, true}, true});
}

/// The stops added to `route`.
int CountStops(const std::vector<RoutePoint>& route) {
  return static_cast<int>(std::count_if(route.begin(), route.end(),
                                        [](const RoutePoint& p) { return p.added && p.via.stop; }));
}

/// The route points of a space-time `route` on `graph`: its guides (route_guides.hpp), at
/// most `max_points`.
std::vector<RoutePoint> RoutePointsOf(const SurfaceGraph& graph,
                                      const fleet_internal::SpaceTimeRoute& route, int max_points) {
  std::vector<double> along_m(route.nodes.size(), 0.0);
  for (std::size_t k = 1; k < route.nodes.size(); ++k) {
    along_m[k] = along_m[k - 1] +
                 (graph.position(route.nodes[k]) - graph.position(route.nodes[k - 1])).norm();
  }
  std::vector<RoutePoint> points;
  for (const fleet_internal::RouteGuide& guide : fleet_internal::ChooseGuides(
           along_m, route.wait_s, kMaxAddedStops, max_points, kMinStopSpacingM)) {
    points.push_back(RoutePoint{Via{graph.position(route.nodes[guide.index]), guide.stop}, true});
  }
  return points;
}

/// A route searched in space and time: the points a plan through it is guided by, and its way
/// without the waits as a motion, straight from node to node at the search's pace.
struct SpaceTimeGuides {
  std::vector<RoutePoint> points;
  FleetMotion unwaited;
};

/// `route`'s way on `graph` without its waits, leaving at the departure: a 3-D motion of the
/// request's body, whose height is the tallest the robot may take.
FleetMotion UnwaitedWay(const SurfaceGraph& graph, const fleet_internal::SpaceTimeRoute& route,
                        const Traffic& traffic) {
  Trajectory way;
  for (std::size_t k = 0; k + 1 < route.nodes.size(); ++k) {
    // The move's time: from leaving node k to arriving at node k + 1.
    const double move_s = route.leave_s[k + 1] - route.wait_s[k + 1] - route.leave_s[k];
    const Eigen::Vector3d from = graph.position(route.nodes[k]);
    const Eigen::Vector3d to = graph.position(route.nodes[k + 1]);
    TrajectoryPiece piece;
    piece.duration_s = move_s;
    piece.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
    piece.coefficients.row(0) = from.transpose();
    piece.coefficients.row(1) = ((to - from) / move_s).transpose();
    way.pieces.push_back(std::move(piece));
  }
  return traffic.MotionOf(way);
}

/// A route for `request` that keeps out of the way of `traffic` in space and time
/// (space_time_search.hpp), timed as `plain` (the route planned without them) is; none when the
/// search finds none.
std::optional<SpaceTimeGuides> SearchSpaceTimeRoute(const PlanningMap& map,
                                                    const PlanRequest& request,
                                                    const PlanResult& plain, const Traffic& traffic,
                                                    double max_wait_s,
                                                    const std::function<bool()>& should_stop) {
  const auto graph = map.Graph(request.profile.Traversability());
  if (!graph || plain.path.cost <= 0 || plain.stats.duration_s <= 0) return std::nullopt;
  fleet_internal::SpaceTimeOptions options;
  options.cost_per_s = plain.path.cost / plain.stats.duration_s;
  options.terms = request.options.search;
  options.max_wait_s = max_wait_s;
  options.horizon_s = LatestArrivalS(max_wait_s, plain.stats.duration_s);
  const std::vector<KeepOutZone> zones = CollectKeepOut(map, request.keep_out);
  std::function<bool(int)> blocked;
  if (!zones.empty()) {
    blocked = [&](int node) {
      return FirstViolatedKeepOut(zones, request.profile, graph.value()->position(node)) >= 0;
    };
  }
  const std::optional<fleet_internal::SpaceTimeRoute> found = fleet_internal::SearchSpaceTime(
      *graph.value(), plain.start.node, plain.goal.node, traffic, options, blocked, should_stop);
  if (!found || found->nodes.size() < 2) return std::nullopt;
  return SpaceTimeGuides{RoutePointsOf(*graph.value(), *found, kMaxVias - kMaxAddedStops),
                         UnwaitedWay(*graph.value(), *found, traffic)};
}

/// `plan` with `waits_s[k]` at rest before each of its `legs`: the trajectory, its stats, the
/// request's vias' times, and the holds.
FleetPlanResult WithWaits(PlanResult plan, const std::vector<Trajectory>& legs,
                          const std::vector<double>& waits_s,
                          const std::vector<RoutePoint>& route) {
  FleetPlanResult result;
  Trajectory waiting;
  waiting.dimension = plan.trajectory.dimension;
  double elapsed_s = 0;
  for (std::size_t k = 0; k < legs.size(); ++k) {
    if (waits_s[k] > 0) {
      waiting.pieces.push_back(fleet_internal::RestAtStart(legs[k], waits_s[k]));
      result.holds.push_back({elapsed_s, waits_s[k], legs[k].Position(0).head<3>()});
      elapsed_s += waits_s[k];
      result.wait_s += waits_s[k];
    }
    waiting.pieces.insert(waiting.pieces.end(), legs[k].pieces.begin(), legs[k].pieces.end());
    elapsed_s += legs[k].TotalDuration();
  }
  // A route point in leg k is reached after the waits before legs 0..k.
  std::vector<SnapResult> vias;
  std::vector<double> via_times_s;
  std::size_t leg = 0;
  double waited_s = waits_s[0];
  for (std::size_t j = 0; j < route.size(); ++j) {
    if (!route[j].added) {
      vias.push_back(plan.via[j]);
      via_times_s.push_back(plan.via_times_s[j] + waited_s);
    } else if (route[j].via.stop) {
      ++result.stops_added;
    }
    if (route[j].via.stop) waited_s += waits_s[++leg];
  }
  plan.via = std::move(vias);
  plan.via_times_s = std::move(via_times_s);
  plan.trajectory = std::move(waiting);
  plan.stats.duration_s += result.wait_s;
  plan.stats.pieces = static_cast<int>(plan.trajectory.pieces.size());
  result.plan = std::move(plan);
  return result;
}

/// Where a robot of `request`, parked at its goal, waits for another robot that passes there
/// (`taken`, GoalTakenLater) before coming back: a place off that robot's way, found as a stop
/// before `last_leg`'s end is (StopBefore). None when there is none.
std::optional<Eigen::Vector3d> PlaceToMakeWay(const PlanningMap& map, const PlanRequest& request,
                                              const PlanResult& plan, const Trajectory& last_leg,
                                              const TrafficConflict& taken, const Traffic& traffic,
                                              const std::function<bool()>& should_stop) {
  const auto graph = map.Graph(request.profile.Traversability());
  if (!graph) return std::nullopt;
  const std::vector<KeepOutZone> zones = CollectKeepOut(map, request.keep_out);
  const std::optional<AddedStop> place = StopBefore(
      last_leg, traffic.departure_ns, taken, traffic,
      [&](const Eigen::Vector3d& p) -> std::optional<Eigen::Vector3d> {
        return StandingPoint(*graph.value(), zones, request.profile, plan.goal.node, p);
      },
      should_stop);
  if (!place) return std::nullopt;
  return place->position_m;
}

/// A leg of `request`'s robot from rest at `from` to rest at `to`, planned (and verified) by
/// Plan; none unless it plans, begins at `from` (within kLegJoinM: the legs it joins meet) and
/// ends at `to` (within kLegEndM: Plan snaps the goal anew).
std::optional<PlanResult> LegBetween(const PlanningMap& map, const PlanRequest& request,
                                     const StateVector& from, const StateVector& to,
                                     const std::function<bool()>& should_stop) {
  PlanRequest leg;
  leg.start.position_m = from.head<3>();
  leg.goal.position_m = to.head<3>();
  leg.profile = request.profile;
  leg.options = request.options;
  leg.keep_out = request.keep_out;
  Expected<PlanResult> planned = Plan(map, leg, should_stop);
  if (!planned) return std::nullopt;
  const Trajectory& trajectory = planned.value().trajectory;
  const StateVector first = trajectory.Position(0);
  const StateVector last = trajectory.Position(trajectory.TotalDuration());
  if (first.size() != from.size() || (first - from).norm() > kLegJoinM ||
      (last - to).norm() > kLegEndM) {
    return std::nullopt;
  }
  return std::move(planned).value();
}

/// Whether the hold search's `failure` on `legs` met another robot only once the route had
/// reached its goal: the robot parked there is in that robot's way.
bool MetWhenParked(const fleet_internal::HoldFailure& failure,
                   const std::vector<Trajectory>& legs) {
  return failure.conflict && failure.leg + 1 == legs.size() &&
         failure.conflict->conflict.time_ns >=
             AddSeconds(failure.departure_ns, legs.back().TotalDuration());
}

/// Whether no waits up to `max_wait_s` clear `plan` (through `route`) of the robots that move
/// (`traffic.others` but those `zoned` and the `parked` ones, which the plan would go around
/// next), at a meeting on the way before the route first comes near a `parked` one: going
/// around those would not change it. Not when the route meets them only once parked at its goal
/// (making way is for that). Adds the departures it checks to `*departures_checked`.
bool WaitsFailBeforeParked(const PlanResult& plan, const std::vector<RoutePoint>& route,
                           const Traffic& traffic, const ParkedInWay& parked,
                           const std::vector<bool>& zoned, double max_wait_s,
                           int* departures_checked) {
  std::vector<ReservedMotion> moving;
  for (std::size_t i = 0; i < traffic.others.size(); ++i) {
    if (!zoned[i] &&
        std::find(parked.robots.begin(), parked.robots.end(), i) == parked.robots.end()) {
      moving.push_back(traffic.others[i]);
    }
  }
  Traffic among_moving = traffic;
  among_moving.others = moving;
  const std::vector<Trajectory> legs = SplitAtStops(plan, route);
  const auto scheduled = fleet_internal::ScheduleHolds(
      legs, StartsAtRest(plan.trajectory), among_moving, max_wait_s, kMaxDeparturesChecked);
  const auto* failure = std::get_if<fleet_internal::HoldFailure>(&scheduled);
  if (failure == nullptr) {
    *departures_checked += std::get<fleet_internal::HoldSchedule>(scheduled).departures_checked;
    return false;
  }
  *departures_checked += failure->departures_checked;
  if (!failure->conflict || MetWhenParked(*failure, legs)) return false;
  // How far along the route (its time without waits) the meeting is, against the parked robots.
  double meeting_s = SecondsBetween(failure->departure_ns, failure->conflict->conflict.time_ns);
  for (std::size_t k = 0; k < failure->leg; ++k) meeting_s += legs[k].TotalDuration();
  return meeting_s < SecondsBetween(traffic.departure_ns, parked.first_near_ns);
}

/// `plan` (through `route`, cut into `legs`) for a goal that a robot passes after this one has
/// arrived (`taken`): at the goal the robot makes way for it. It holds at the goal as long as
/// it can, leaves for a place beside it off that robot's way, holds there until the way is
/// clear and comes back, parked until its lease. The arrival is as the route's, within
/// max_wait_s; the time at the goal and beside it is parked time (up to kLongestTripS and
/// kMakeWayAsideS). None when that robot comes to stay at the goal, or there is no such place,
/// or no waits clear the traffic.
std::optional<FleetPlanResult> MakeWayAtGoal(const PlanningMap& map, const PlanRequest& request,
                                             PlanResult plan, std::vector<RoutePoint> route,
                                             std::vector<Trajectory> legs,
                                             const TrafficConflict& taken, const Traffic& traffic,
                                             double max_wait_s,
                                             const std::function<bool()>& should_stop,
                                             int* departures_checked) {
  const StateVector goal = legs.back().Position(legs.back().TotalDuration());
  // A robot that comes to stay at the goal is not made way for.
  const FleetMotion& other = traffic.others[taken.other].motion;
  if (other.end_ns > other.ArrivalNs() &&
      FirstTrafficConflict(
          Standing(goal, plan.trajectory.dimension, traffic.body, other.ArrivalNs(), other.end_ns),
          traffic.others.subspan(taken.other, 1), traffic.rule)) {
    return std::nullopt;
  }
  const std::optional<Eigen::Vector3d> place =
      PlaceToMakeWay(map, request, plan, legs.back(), taken, traffic, should_stop);
  if (!place) return std::nullopt;
  StateVector aside = goal;
  aside.head<3>() = *place;
  std::optional<PlanResult> away = LegBetween(map, request, goal, aside, should_stop);
  if (!away) return std::nullopt;
  aside = away->trajectory.Position(away->trajectory.TotalDuration());
  std::optional<PlanResult> back = LegBetween(map, request, aside, goal, should_stop);
  if (!back) return std::nullopt;

  const std::size_t arrival_legs = legs.size();
  legs.push_back(away->trajectory);
  legs.push_back(back->trajectory);
  const auto scheduled = fleet_internal::ScheduleHolds(
      legs, StartsAtRest(plan.trajectory), traffic, max_wait_s, kMaxDeparturesChecked,
      fleet_internal::ParkedLegs{arrival_legs, kLongestTripS, kMakeWayAsideS});
  if (const auto* failure = std::get_if<fleet_internal::HoldFailure>(&scheduled)) {
    *departures_checked += failure->departures_checked;
    return std::nullopt;
  }
  const auto& holds = std::get<fleet_internal::HoldSchedule>(scheduled);
  *departures_checked += holds.departures_checked;
  double arrival_s = 0;
  for (std::size_t k = 0; k < arrival_legs; ++k) {
    arrival_s += holds.waits_s[k] + legs[k].TotalDuration();
  }
  // The two legs join the plan as stops at the goal and beside it.
  for (const PlanResult* leg : {&*away, &*back}) {
    plan.trajectory.pieces.insert(plan.trajectory.pieces.end(), leg->trajectory.pieces.begin(),
                                  leg->trajectory.pieces.end());
    plan.stats.duration_s += leg->stats.duration_s;
    plan.stats.length_m += leg->stats.length_m;
  }
  route.push_back(RoutePoint{Via{goal.head<3>(), true}, true});
  route.push_back(RoutePoint{Via{aside.head<3>(), true}, true});
  FleetPlanResult result = WithWaits(std::move(plan), legs, holds.waits_s, route);
  result.stops_added -= 2;
  result.arrival_s = arrival_s;
  result.makes_way = true;
  result.motion = traffic.MotionOf(result.plan.trajectory);
  return result;
}

/// PlanAmongTraffic without replanning anyone: the robot keeps out of the way of every motion
/// committed before it. Its legs go through `legs` (CommitOrderPlanner), or a cache of its own.
Expected<FleetPlanResult> PlanInCommitOrder(const PlanningMap& map, const FleetPlanRequest& request,
                                            const std::function<bool()>& should_stop,
                                            LegCache* legs) {
  if (Status s = request.plan.Validate(); !s) return s.error();
  if (Status s = request.fleet.Validate("fleet"); !s) return s.error();
  const Traffic traffic = TrafficOf(request);

  PlanRequest plan_request = request.plan;
  std::vector<RoutePoint> route;
  for (const Via& via : request.plan.via) route.push_back({via, false});
  const int max_added_stops =
      std::min(kMaxAddedStops, kMaxVias - static_cast<int>(request.plan.via.size()));
  int stops_added = 0;
  std::vector<bool> zoned(request.others.size(), false);
  // Zoned, or parked on the start only after the departure: this robot must leave before that
  // one arrives, which the waits' exact checks see; ParkedInTheWay looks at neither again.
  std::vector<bool> settled(request.others.size(), false);
  const auto zoned_count = [&] {
    return static_cast<int>(std::count(zoned.begin(), zoned.end(), true));
  };
  // Plans around robot `i`, parked inside `zone`, from the next plan on.
  const auto add_zone = [&](std::size_t i, Prism zone) {
    plan_request.keep_out.push_back(std::move(zone));
    zoned[i] = true;
    settled[i] = true;
  };
  // Robots parked from the departure for longer than any trip this plan could make are
  // planned around from the first plan on, which saves the plan that would find them.
  // (One on the start or the goal is left to the rounds, which refuse it by name.)
  const std::int64_t long_parked_ns =
      AddSeconds(request.departure_ns, request.fleet.max_wait_s + kLongestTripS);
  const RobotProfile& profile = request.plan.profile;
  const std::array request_ends = {request.plan.start.position_m, request.plan.goal.position_m};
  for (std::size_t i = 0; i < request.others.size(); ++i) {
    const FleetMotion& other = request.others[i].motion;
    if (other.ArrivalNs() > request.departure_ns || other.end_ns < long_parked_ns ||
        plan_request.keep_out.size() >= static_cast<std::size_t>(kMaxRequestKeepOutZones)) {
      continue;
    }
    Prism zone = ParkedZone(other, traffic.rule, profile, request_ends);
    if (ViolatesKeepOut(zone, profile, request.plan.start.position_m) ||
        ViolatesKeepOut(zone, profile, request.plan.goal.position_m)) {
      continue;
    }
    add_zone(i, std::move(zone));
  }
  // Makes every robot of `parked` a keep-out zone, to plan around them all at once, and drops
  // the points added to the route that a zone covers. False when that is more zones than a
  // request may have; sets zone_error when one stands on the goal of `plan`, or on its start
  // from the departure on (one that arrives there later is left to the waits: settled).
  std::optional<Error> zone_error;
  const auto zone_parked = [&](const std::vector<std::size_t>& parked, const PlanResult& plan) {
    if (plan_request.keep_out.size() + parked.size() >
        static_cast<std::size_t>(kMaxRequestKeepOutZones)) {
      return false;
    }
    const std::array ends = {plan.start.position_m, plan.goal.position_m};
    for (const std::size_t i : parked) {
      const ReservedMotion& other = request.others[i];
      Prism zone = ParkedZone(other.motion, traffic.rule, profile, ends);
      if (ViolatesKeepOut(zone, profile, plan.goal.position_m)) {
        zone_error = ParkedOnEnd(other, request, "goal");
        return true;
      }
      if (ViolatesKeepOut(zone, profile, plan.start.position_m)) {
        if (other.motion.ArrivalNs() <= request.departure_ns) {
          zone_error = ParkedOnEnd(other, request, "start");
          return true;
        }
        settled[i] = true;
        continue;
      }
      add_zone(i, std::move(zone));
    }
    std::erase_if(route, [&](const RoutePoint& point) {
      return point.added &&
             std::any_of(plan_request.keep_out.begin(), plan_request.keep_out.end(),
                         [&](const Prism& zone) {
                           return ViolatesKeepOut(zone, profile, point.via.position_m);
                         });
    });
    stops_added = CountStops(route);
    return true;
  };
  bool space_time_tried = false;
  // Searches a route in space and time (once a request) timed as `plain`, and makes it the
  // route. Robots parked on its way are planned around from the plan through it on, which saves
  // the plan that would find them (zone_error set as zone_parked sets it). False when the
  // search finds none.
  const auto search_route = [&](const PlanResult& plain) {
    space_time_tried = true;
    std::optional<SpaceTimeGuides> guides = SearchSpaceTimeRoute(
        map, plan_request, plain, traffic, request.fleet.max_wait_s, should_stop);
    if (!guides) return false;
    route = std::move(guides->points);
    stops_added = CountStops(route);
    const ParkedInWay parked_on_way = ParkedInTheWay(
        guides->unwaited, traffic, request.fleet.max_wait_s, settled, kParkedOnWayReachM);
    if (!parked_on_way.robots.empty()) zone_parked(parked_on_way.robots, plain);
    return true;
  };
  int departures_checked = 0;
  int make_way_rounds = 0;
  const auto stopped = [&] { return should_stop && should_stop(); };
  // The rounds replan the same legs but for the one a stop splits (and all of them when a zone
  // is added, which the cache compares).
  LegCache own_legs;
  if (legs == nullptr) legs = &own_legs;
  std::optional<TrafficConflict> first_at_departure;
  for (int round = 0; round < kMaxPlanRounds; ++round) {
    plan_request.via.clear();
    for (const RoutePoint& point : route) plan_request.via.push_back(point.via);
    Expected<PlanResult> plan = Plan(map, plan_request, should_stop, legs);
    if (!plan && (stops_added > 0 || space_time_tried) &&
        plan.error().code != ErrorCode::kCancelled &&
        plan.error().code != ErrorCode::kDeadlineExceeded) {
      // A route of its own (stops, a space-time route) did not plan: refuse with what the
      // route met.
      break;
    }
    if (!plan) {
      if (zoned_count() > 0 && plan.error().code == ErrorCode::kGoalUnreachable) {
        std::string robots;
        for (std::size_t i = 0; i < zoned.size(); ++i) {
          if (zoned[i]) robots += (robots.empty() ? "" : ", ") + request.others[i].robot_id;
        }
        return Error{ErrorCode::kReservationConflict,
                     fmt::format("robots parked in the way ({}) close every way to the goal: {}",
                                 robots, plan.error().message)};
      }
      return plan.error();
    }
    if (stopped()) return CancelledWhile("waits were tried");
    const FleetMotion unwaited = traffic.MotionOf(plan.value().trajectory);
    if (std::optional<TrafficConflict> met =
            FirstTrafficConflict(unwaited, traffic.others, traffic.rule)) {
      first_at_departure = met;
    }
    const ParkedInWay parked = ParkedInTheWay(unwaited, traffic, request.fleet.max_wait_s, settled);
    if (!parked.robots.empty()) {
      // Where no waits clear the robots that move on this route before it nears the parked
      // ones, going around those clears nothing: the route is searched in space and time at
      // once, around them.
      const bool search_now =
          !space_time_tried && request.plan.via.empty() &&
          WaitsFailBeforeParked(plan.value(), route, traffic, parked, zoned,
                                request.fleet.max_wait_s, &departures_checked) &&
          !GoalTakenLater(plan.value().trajectory, traffic,
                          LatestArrivalS(request.fleet.max_wait_s, plan.value().stats.duration_s));
      if (!zone_parked(parked.robots, plan.value())) break;
      if (zone_error) return *zone_error;
      if (search_now && search_route(plan.value()) && zone_error) return *zone_error;
      continue;
    }
    const std::vector<Trajectory> legs = SplitAtStops(plan.value(), route);
    const auto scheduled =
        fleet_internal::ScheduleHolds(legs, StartsAtRest(plan.value().trajectory), traffic,
                                      request.fleet.max_wait_s, kMaxDeparturesChecked);
    if (const auto* holds = std::get_if<fleet_internal::HoldSchedule>(&scheduled)) {
      // Plan verified every leg on the map; each wait holds a leg's verified first point at
      // rest, and ScheduleHolds checked the whole route, waits included, against the traffic
      // exactly.
      FleetPlanResult result = WithWaits(std::move(plan).value(), legs, holds->waits_s, route);
      result.arrival_s = result.plan.stats.duration_s;
      result.motion = traffic.MotionOf(result.plan.trajectory);
      result.parked_robots_avoided = zoned_count();
      result.departures_checked = departures_checked + holds->departures_checked;
      result.plan_rounds = round + 1;
      return result;
    }
    const auto& failure = std::get<fleet_internal::HoldFailure>(scheduled);
    departures_checked += failure.departures_checked;
    // Makes way at the goal for the robot that meets this one there (`taken`), one of
    // kMaxMakeWayRounds: the plan that does, the answer to a caller that stopped it, or none.
    const auto make_way =
        [&](const TrafficConflict& taken) -> std::optional<Expected<FleetPlanResult>> {
      ++make_way_rounds;
      std::optional<FleetPlanResult> made =
          MakeWayAtGoal(map, plan_request, plan.value(), route, legs, taken, traffic,
                        request.fleet.max_wait_s, should_stop, &departures_checked);
      if (!made) {
        if (stopped()) return Expected<FleetPlanResult>(CancelledWhile("making way was tried"));
        return std::nullopt;
      }
      made->parked_robots_avoided = zoned_count();
      made->departures_checked = departures_checked;
      made->plan_rounds = round + 1;
      return Expected<FleetPlanResult>(std::move(*made));
    };
    // The route reached the goal and was met there, parked: the robot makes way there.
    bool make_way_tried = false;
    if (MetWhenParked(failure, legs) && make_way_rounds < kMaxMakeWayRounds) {
      make_way_tried = true;
      if (std::optional<Expected<FleetPlanResult>> answer = make_way(*failure.conflict)) {
        return std::move(*answer);
      }
    }
    if (!space_time_tried && request.plan.via.empty()) {
      // No waits clear the route. Where this robot, parked at its goal, is met by another even
      // when it arrives as late as the search goes, no route, wait or stop clears it.
      const double latest_s =
          LatestArrivalS(request.fleet.max_wait_s, plan.value().stats.duration_s);
      if (std::optional<TrafficConflict> taken =
              GoalTakenLater(plan.value().trajectory, traffic, latest_s)) {
        // A robot that passes the goal later: this one arrives, and makes way for it there.
        if (!make_way_tried && make_way_rounds < kMaxMakeWayRounds) {
          if (std::optional<Expected<FleetPlanResult>> answer = make_way(*taken)) {
            return std::move(*answer);
          }
        }
        return GoalTaken(*taken, request, latest_s);
      }
      if (search_route(plan.value())) {
        if (zone_error) return *zone_error;
        continue;
      }
    }
    if (!failure.conflict || stops_added >= max_added_stops) break;
    // Looked up once for every place the stop search tries (Plan has just built the graph).
    const auto graph = map.Graph(request.plan.profile.Traversability());
    const std::vector<KeepOutZone> zones = CollectKeepOut(map, plan_request.keep_out);
    const std::optional<AddedStop> stop = StopBefore(
        legs[failure.leg], failure.departure_ns, *failure.conflict, traffic,
        [&](const Eigen::Vector3d& p) -> std::optional<Eigen::Vector3d> {
          if (!graph) return std::nullopt;
          return StandingPoint(*graph.value(), zones, request.plan.profile, plan.value().start.node,
                               p);
        },
        should_stop);
    if (!stop && stopped()) return CancelledWhile("stops were looked for");
    if (!stop) break;
    double leg_start_s = 0;
    for (std::size_t k = 0; k < failure.leg; ++k) leg_start_s += legs[k].TotalDuration();
    InsertStop(route, plan.value(), leg_start_s + stop->leg_time_s, stop->position_m);
    ++stops_added;
  }
  // Nothing cleared the traffic: name what the route without waits met.
  if (!first_at_departure) {
    return Error{
        ErrorCode::kReservationConflict,
        fmt::format("no plan kept clear of the other robots within {} plans", kMaxPlanRounds)};
  }
  const ReservedMotion& other = request.others[first_at_departure->other];
  const MotionConflict& c = first_at_departure->conflict;
  const bool at_start = c.time_ns == request.departure_ns;
  Error error{
      ErrorCode::kReservationConflict,
      fmt::format("{} robot {}'s reservation at ({:.2f}, {:.2f}, {:.2f}) m, {} (the "
                  "robots come within {:.3f} m, the limit is {:.3f} m), and no waits up to "
                  "{:g} s in all, at the start or at up to {} stops on the way, clear every "
                  "reservation; ask again in a few seconds, once the robots in the way have "
                  "moved on, or plan to another goal",
                  at_start ? "the start is already in conflict with" : "the trajectory meets",
                  internal::Quote(other.robot_id), c.point_a.x(), c.point_a.y(), c.point_a.z(),
                  TimeText(request.departure_ns, c.time_ns), c.horizontal_distance_m, c.limit_m,
                  request.fleet.max_wait_s, max_added_stops)};
  error.details = ConflictDetails(other.robot_id, c);
  return error;
}

/// `request` planned at its departure: in commit order, then, when refused and allowed,
/// replanning the robots in the way (replan_in_the_way.hpp). Legs through `legs`.
Expected<FleetPlanResult> PlanAtDeparture(const PlanningMap& map, const FleetPlanRequest& request,
                                          const std::function<bool()>& should_stop,
                                          LegCache* legs) {
  Expected<FleetPlanResult> planned = PlanInCommitOrder(map, request, should_stop, legs);
  if (planned || planned.error().code != ErrorCode::kReservationConflict ||
      request.fleet.replan.max_robots == 0 || request.replannable.empty()) {
    return planned;
  }
  return fleet_internal::PlanReplanningOthers(
      request, std::move(planned).error(), legs, [&](const FleetPlanRequest& r, LegCache* cache) {
        return PlanInCommitOrder(map, r, should_stop, cache);
      });
}

}  // namespace

Status ReplanOptions::Validate(std::string_view path) const {
  if (!(max_robots >= 0 && max_robots <= kMaxReplannedRobots)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_robots"), max_robots,
                                fmt::format("in [0, {}]", kMaxReplannedRobots));
  }
  if (!(notice_s >= 0 && notice_s <= kMaxReplanNoticeS)) {
    return internal::OutOfRange(internal::FieldPath(path, "notice_s"), notice_s,
                                fmt::format("in [0, {:g}] s", kMaxReplanNoticeS));
  }
  if (!(max_wait_s >= 0 && max_wait_s <= 3600)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_wait_s"), max_wait_s,
                                "in [0, 3600] s");
  }
  return Status::Ok();
}

Status FleetPlanOptions::Validate(std::string_view path) const {
  if (Status s = rule.Validate(internal::FieldPath(path, "rule")); !s) return s;
  if (!(max_wait_s >= 0 && max_wait_s <= 3600)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_wait_s"), max_wait_s,
                                "in [0, 3600] s");
  }
  return replan.Validate(internal::FieldPath(path, "replan"));
}

Expected<FleetPlanResult> PlanAmongTraffic(const PlanningMap& map, const FleetPlanRequest& request,
                                           const std::function<bool()>& should_stop) {
  for (std::size_t i = 0; i < request.replannable.size(); ++i) {
    const ReplannableRobot& robot = request.replannable[i];
    const std::string path = fmt::format("replannable[{}]", i);
    if (robot.other >= request.others.size()) {
      return Error{ErrorCode::kInvalidInput,
                   fmt::format("{}.other is {}, beyond the {} others", path, robot.other,
                               request.others.size()),
                   path + ".other"};
    }
    if (Status s = robot.profile.Validate(path + ".profile"); !s) return s.error();
  }
  // Every try (replanning others, departing later) takes its legs from here: at least the first
  // plan, made without the others, comes out the same in each.
  LegCache legs;
  Expected<FleetPlanResult> planned = PlanAtDeparture(map, request, should_stop, &legs);
  if (planned) return planned;
  return fleet_internal::PlanLeavingLater(request, std::move(planned).error(), &legs,
                                          [&](const FleetPlanRequest& later, LegCache* cache) {
                                            return PlanAtDeparture(map, later, should_stop, cache);
                                          });
}

}  // namespace strata
