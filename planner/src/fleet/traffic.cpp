#include "strata/fleet/traffic.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "format_internal.hpp"

namespace strata {

FleetMotion Traffic::MotionOf(const Trajectory& trajectory) const {
  FleetMotion motion;
  motion.start_ns = departure_ns;
  motion.trajectory = trajectory;
  motion.body = body;
  motion.end_ns = std::max(parked_until_ns, motion.ArrivalNs());
  motion.separation_m = rule.separation_m;
  return motion;
}

std::optional<TrafficConflict> FirstTrafficConflict(const FleetMotion& own,
                                                    std::span<const ReservedMotion> others,
                                                    const SeparationRule& rule) {
  return FirstTrafficConflict(own, PrepareOthers(others), rule);
}

std::optional<TrafficConflict> FirstTrafficConflict(const FleetMotion& own,
                                                    std::span<const PreparedMotion> others,
                                                    const SeparationRule& rule) {
  const PreparedMotion mine(own);
  std::optional<TrafficConflict> first;
  for (std::size_t i = 0; i < others.size(); ++i) {
    std::optional<MotionConflict> conflict = FirstConflict(mine, others[i], rule);
    if (conflict && (!first || conflict->time_ns < first->conflict.time_ns)) {
      first = TrafficConflict{i, *conflict};
    }
  }
  return first;
}

std::vector<PreparedMotion> PrepareOthers(std::span<const ReservedMotion> others) {
  std::vector<PreparedMotion> prepared;
  prepared.reserve(others.size());
  for (const ReservedMotion& other : others) prepared.emplace_back(other.motion);
  return prepared;
}

std::map<std::string, std::string> ConflictDetails(const std::string& robot_id,
                                                   const MotionConflict& conflict) {
  return {{"robot_id", robot_id},
          {"time_ns", std::to_string(conflict.time_ns)},
          {"x_m", DetailNumber(conflict.point_a.x())},
          {"y_m", DetailNumber(conflict.point_a.y())},
          {"z_m", DetailNumber(conflict.point_a.z())}};
}

Status CheckSeparation(const FleetMotion& own, std::span<const ReservedMotion> others,
                       const SeparationRule& rule) {
  const std::optional<TrafficConflict> first = FirstTrafficConflict(own, others, rule);
  if (!first) return Status::Ok();
  const MotionConflict& c = first->conflict;
  const std::string& robot = others[first->other].robot_id;
  Error error{ErrorCode::kReservationConflict,
              fmt::format("the trajectory meets robot {}'s reservation {:.3f} s after it starts: "
                          "at ({:.2f}, {:.2f}, {:.2f}) m it is {:.3f} m from that robot at "
                          "({:.2f}, {:.2f}, {:.2f}) m, where the two bodies and the separation "
                          "need {:.3f} m",
                          internal::Quote(robot), SecondsBetween(own.start_ns, c.time_ns),
                          c.point_a.x(), c.point_a.y(), c.point_a.z(), c.horizontal_distance_m,
                          c.point_b.x(), c.point_b.y(), c.point_b.z(), c.limit_m)};
  error.details = ConflictDetails(robot, c);
  return error;
}

}  // namespace strata
