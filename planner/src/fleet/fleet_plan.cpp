#include "strata/fleet/fleet_plan.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "format_internal.hpp"

namespace strata {
namespace {

// Another robot parked in the way becomes a zone this much wider than the limit, so that the
// optimiser's footprint, kept out of the polygon, clears the exact check's tolerance.
constexpr double kParkedZoneMarginM = 0.02;
constexpr int kParkedZoneCorners = 12;
// Plans made for one request at most: the first, and one more each time robots parked in the
// way are found (all that the trajectory meets at once).
constexpr int kMaxPlanRounds = 8;

/// The waits tried, shortest first: half-second steps, then growing by a quarter, up to and
/// including max_wait_s.
std::vector<double> WaitLadder(double max_wait_s) {
  std::vector<double> waits = {0.0};
  for (double w = 0.5; w < max_wait_s; w = std::max(w + 0.5, w * 1.25)) waits.push_back(w);
  if (max_wait_s > 0) waits.push_back(max_wait_s);
  return waits;
}

/// `trajectory` preceded by a piece of `wait_s` at rest at its start.
Trajectory WithWaitAtStart(const Trajectory& trajectory, double wait_s) {
  if (wait_s <= 0) return trajectory;
  TrajectoryPiece hold;
  hold.duration_s = wait_s;
  hold.coefficients = Eigen::MatrixXd::Zero(6, trajectory.dimension);
  hold.coefficients.row(0) = trajectory.EvaluatePiece(0, 0, 0).transpose();
  Trajectory waiting = trajectory;
  waiting.pieces.insert(waiting.pieces.begin(), hold);
  return waiting;
}

bool StartsAtRest(const Trajectory& trajectory) {
  return trajectory.EvaluatePiece(0, 0, 1).isZero(1e-9) &&
         trajectory.EvaluatePiece(0, 0, 2).isZero(1e-9);
}

/// A zone around where `other` stays parked: a polygon around the disc of its radius plus
/// the separation (a robot whose footprint stays out of it keeps the limit), over the height
/// its body takes there.
Prism ParkedZone(const FleetMotion& other, const SeparationRule& rule) {
  const Eigen::Vector3d at = other.ReferencePointAt(other.end_ns);
  const VerticalExtent extent = other.ExtentAt(other.end_ns);
  // The polygon's edges lie this far from its centre.
  const double inner = other.body.radius_m + rule.separation_m + kParkedZoneMarginM;
  const double corner = inner / std::cos(std::numbers::pi / kParkedZoneCorners);
  Prism zone;
  for (int k = 0; k < kParkedZoneCorners; ++k) {
    const double angle = 2 * std::numbers::pi * (k + 0.5) / kParkedZoneCorners;
    zone.polygon_m.emplace_back(at.x() + corner * std::cos(angle),
                                at.y() + corner * std::sin(angle));
  }
  zone.z_min_m = extent.bottom_m;
  zone.z_max_m = std::max(extent.top_m, extent.bottom_m);
  return zone;
}

std::string TimeText(std::int64_t from_ns, std::int64_t time_ns) {
  return fmt::format("{:.2f} s after the departure", SecondsBetween(from_ns, time_ns));
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

// Whether `other` stands parked at the conflict and for as long as this robot may take to
// pass: waiting cannot clear it, going around can.
bool ParkedThroughout(const FleetMotion& other, std::int64_t conflict_ns,
                      std::int64_t latest_passage_ns) {
  return conflict_ns >= other.ArrivalNs() && other.end_ns >= latest_passage_ns;
}

/// What the waits at the start found for one planned trajectory.
struct WaitOutcome {
  std::optional<double> clear_wait_s;  ///< The shortest wait that clears every motion.
  std::optional<TrafficConflict> first_at_departure;  ///< What the trajectory meets unwaited.
  /// Robots the trajectory meets where they stand parked for as long as it could take to
  /// pass (waiting cannot clear them, going around can), none already `zoned`.
  std::vector<std::size_t> parked_in_the_way;
  int waits_tried = 0;  ///< Waits longer than zero checked.
};

WaitOutcome TryWaits(const Trajectory& trajectory, const Traffic& traffic, double max_wait_s,
                     const std::vector<bool>& zoned) {
  WaitOutcome outcome;
  const std::vector<double> waits =
      StartsAtRest(trajectory) ? WaitLadder(max_wait_s) : std::vector{0.0};
  const std::int64_t latest_passage_ns =
      AddSeconds(traffic.departure_ns, max_wait_s + trajectory.TotalDuration());
  for (const double wait : waits) {
    const FleetMotion motion = traffic.MotionOf(WithWaitAtStart(trajectory, wait));
    outcome.waits_tried += wait > 0 ? 1 : 0;
    const std::optional<TrafficConflict> first =
        FirstTrafficConflict(motion, traffic.others, traffic.rule);
    if (!first) {
      outcome.clear_wait_s = wait;
      return outcome;
    }
    if (wait == 0) outcome.first_at_departure = first;
    if (zoned[first->other] || !ParkedThroughout(traffic.others[first->other].motion,
                                                 first->conflict.time_ns, latest_passage_ns)) {
      continue;
    }
    // Plan around it, and around every other robot this trajectory meets parked, at once.
    for (std::size_t i = 0; i < traffic.others.size(); ++i) {
      if (zoned[i]) continue;
      const std::optional<MotionConflict> met =
          FirstConflict(motion, traffic.others[i].motion, traffic.rule);
      if (met && ParkedThroughout(traffic.others[i].motion, met->time_ns, latest_passage_ns)) {
        outcome.parked_in_the_way.push_back(i);
      }
    }
    return outcome;
  }
  return outcome;
}

}  // namespace

Status FleetPlanOptions::Validate(std::string_view path) const {
  if (Status s = rule.Validate(internal::FieldPath(path, "rule")); !s) return s;
  if (!(max_wait_s >= 0 && max_wait_s <= 3600)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_wait_s"), max_wait_s,
                                "in [0, 3600] s");
  }
  return Status::Ok();
}

Expected<FleetPlanResult> PlanAmongTraffic(const PlanningMap& map, const FleetPlanRequest& request,
                                           const std::function<bool()>& should_stop) {
  if (Status s = request.plan.Validate(); !s) return s.error();
  if (Status s = request.fleet.Validate("fleet"); !s) return s.error();
  Traffic traffic;
  traffic.departure_ns = request.departure_ns;
  traffic.parked_until_ns = request.parked_until_ns;
  traffic.body = FleetBody::FromProfile(request.plan.profile);
  traffic.rule = request.fleet.rule;
  traffic.others = request.others;

  PlanRequest plan_request = request.plan;
  std::vector<bool> zoned(request.others.size(), false);
  const auto zoned_count = [&] {
    return static_cast<int>(std::count(zoned.begin(), zoned.end(), true));
  };
  int waits_tried = 0;
  std::optional<TrafficConflict> first_at_departure;
  for (int round = 0; round < kMaxPlanRounds; ++round) {
    Expected<PlanResult> plan = Plan(map, plan_request, should_stop);
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
    if (should_stop && should_stop()) {
      return Error{ErrorCode::kCancelled, "the plan was cancelled while waits were tried"};
    }
    const WaitOutcome waits =
        TryWaits(plan.value().trajectory, traffic, request.fleet.max_wait_s, zoned);
    waits_tried += waits.waits_tried;
    if (waits.first_at_departure) first_at_departure = waits.first_at_departure;
    if (waits.clear_wait_s) {
      // Plan verified the trajectory on the map; the wait holds its verified start at rest,
      // and TryWaits checked the whole of it against the traffic exactly.
      const double wait = *waits.clear_wait_s;
      FleetPlanResult result;
      result.plan = std::move(plan).value();
      result.plan.trajectory = WithWaitAtStart(result.plan.trajectory, wait);
      result.plan.stats.duration_s += wait;
      result.plan.stats.pieces = static_cast<int>(result.plan.trajectory.pieces.size());
      for (double& t : result.plan.via_times_s) t += wait;
      result.motion = traffic.MotionOf(result.plan.trajectory);
      result.wait_s = wait;
      result.parked_robots_avoided = zoned_count();
      result.waits_tried = waits_tried;
      return result;
    }
    if (waits.parked_in_the_way.empty() ||
        plan_request.keep_out.size() + waits.parked_in_the_way.size() >
            static_cast<std::size_t>(kMaxRequestKeepOutZones)) {
      break;
    }
    for (const std::size_t i : waits.parked_in_the_way) {
      const ReservedMotion& parked = request.others[i];
      Prism zone = ParkedZone(parked.motion, traffic.rule);
      const RobotProfile& profile = request.plan.profile;
      if (ViolatesKeepOut(zone, profile, plan.value().goal.position_m)) {
        return ParkedOnEnd(parked, request, "goal");
      }
      if (ViolatesKeepOut(zone, profile, plan.value().start.position_m)) {
        return ParkedOnEnd(parked, request, "start");
      }
      plan_request.keep_out.push_back(std::move(zone));
      zoned[i] = true;
    }
  }
  // Nothing cleared the traffic: name what the plan without waiting met.
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
                  "robots come within {:.3f} m, the limit is {:.3f} m), and no wait up "
                  "to {:g} s at the start clears every reservation",
                  at_start ? "the start is already in conflict with" : "the trajectory meets",
                  internal::Quote(other.robot_id), c.point_a.x(), c.point_a.y(), c.point_a.z(),
                  TimeText(request.departure_ns, c.time_ns), c.horizontal_distance_m, c.limit_m,
                  request.fleet.max_wait_s)};
  error.details = ConflictDetails(other.robot_id, c);
  return error;
}

}  // namespace strata
