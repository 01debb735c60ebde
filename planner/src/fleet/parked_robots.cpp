#include "parked_robots.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "strata/fleet/motion_conflict.hpp"

namespace strata::fleet_internal {
namespace {

// Another robot parked in the way becomes a zone this much wider than the limit, so that the
// optimiser's footprint, kept out of the polygon, clears the exact check's tolerance.
constexpr double kParkedZoneMarginM = 0.02;
constexpr int kParkedZoneCorners = 12;

}  // namespace

FleetMotion Standing(const StateVector& state, int dimension, const FleetBody& body,
                     std::int64_t from_ns, std::int64_t until_ns) {
  FleetMotion standing;
  standing.start_ns = from_ns;
  standing.trajectory.dimension = dimension;
  standing.trajectory.pieces = {RestAt(state, SecondsBetween(from_ns, until_ns))};
  standing.body = body;
  standing.end_ns = until_ns;
  return standing;
}

Prism ParkedZone(const FleetMotion& other, const SeparationRule& rule, const RobotProfile& profile,
                 std::span<const Eigen::Vector3d> ends) {
  const Eigen::Vector3d at = other.ReferencePointAt(other.end_ns);
  const VerticalExtent extent = other.ExtentAt(other.end_ns);
  const double disc = other.body.radius_m + PairSeparationM(rule, other);
  const auto polygon = [&](double margin_m, double facing_rad) {
    Prism zone;
    // The polygon's edges lie `inner` from its centre, the middle of one facing `facing_rad`.
    const double inner = disc + margin_m;
    const double corner = inner / std::cos(std::numbers::pi / kParkedZoneCorners);
    for (int k = 0; k < kParkedZoneCorners; ++k) {
      const double angle = facing_rad + 2 * std::numbers::pi * (k + 0.5) / kParkedZoneCorners;
      zone.polygon_m.emplace_back(at.x() + corner * std::cos(angle),
                                  at.y() + corner * std::sin(angle));
    }
    zone.z_min_m = extent.bottom_m;
    zone.z_max_m = std::max(extent.top_m, extent.bottom_m);
    return zone;
  };
  Prism zone = polygon(kParkedZoneMarginM, 0);
  for (const Eigen::Vector3d& end : ends) {
    const Eigen::Vector2d towards = (end - at).head<2>();
    const double room_m = towards.norm() - profile.footprint_radius_m - disc;
    if (room_m > 0 && ViolatesKeepOut(zone, profile, end)) {
      zone =
          polygon(std::min(kParkedZoneMarginM, room_m / 2), std::atan2(towards.y(), towards.x()));
    }
  }
  return zone;
}

ParkedInWay ParkedInTheWay(const FleetMotion& motion, const Traffic& traffic, double max_wait_s,
                           const std::vector<bool>& settled, double reach_m) {
  SeparationRule rule = traffic.rule;
  const std::int64_t latest_passage_ns = AddSeconds(motion.ArrivalNs(), max_wait_s);
  const PreparedMotion route(motion);
  ParkedInWay parked;
  for (std::size_t i = 0; i < traffic.others.size(); ++i) {
    const FleetMotion& other = traffic.others[i].motion;
    if (settled[i] || other.end_ns < latest_passage_ns || other.ArrivalNs() > latest_passage_ns) {
      continue;
    }
    // The other robot standing where it parks for as long as the route could take.
    FleetMotion standing = Standing(other.StateAt(other.ArrivalNs()), other.trajectory.dimension,
                                    other.body, motion.start_ns, latest_passage_ns);
    rule.separation_m = PairSeparationM(traffic.rule, other) + reach_m;
    if (const std::optional<MotionConflict> near =
            FirstConflict(route, PreparedMotion(standing), rule)) {
      parked.robots.push_back(i);
      parked.first_near_ns = std::min(parked.first_near_ns, near->time_ns);
    }
  }
  return parked;
}

}  // namespace strata::fleet_internal
