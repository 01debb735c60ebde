#include "stop_places.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "strata/fleet/motion_conflict.hpp"

namespace strata::fleet_internal {
namespace {

// An added stop keeps this much more than the limit from the way of the robot it waits for.
// Both ways are walked in steps of kStopSearchStepS.
constexpr double kStopClearanceM = 0.3;
constexpr double kStopSearchStepS = 0.1;
// Beside the route, an added stop is looked for at these offsets to either side [m] (a bay
// off an aisle where the robot lets another pass), snapped onto the ground within
// kStandingSnapM.
constexpr std::array<double, 3> kStopSideOffsetsM = {0.8, 1.2, 1.6};
constexpr double kStandingSnapM = 0.3;

bool ExtentsOverlap(const VerticalExtent& a, const VerticalExtent& b) {
  return a.top_m > b.bottom_m && b.top_m > a.bottom_m;
}

}  // namespace

std::optional<AddedStop> StopBefore(
    const Trajectory& leg, std::int64_t departure_ns, const TrafficConflict& met,
    const Traffic& traffic,
    const std::function<std::optional<Eigen::Vector3d>(const Eigen::Vector3d&)>& stands,
    const std::function<bool()>& should_stop) {
  const FleetMotion& other = traffic.others[met.other].motion;
  const double clear_m = traffic.body.radius_m + other.body.radius_m +
                         PairSeparationM(traffic.rule, other) + kStopClearanceM;
  std::vector<std::pair<Eigen::Vector3d, VerticalExtent>> passing;
  const std::int64_t from_ns = std::max(other.start_ns, departure_ns);
  const std::int64_t until_ns = std::max(from_ns, other.ArrivalNs());
  for (std::int64_t t = from_ns; t <= until_ns; t = AddSeconds(t, kStopSearchStepS)) {
    passing.emplace_back(other.ReferencePointAt(t), other.ExtentAt(t));
  }
  passing.emplace_back(other.ReferencePointAt(until_ns), other.ExtentAt(until_ns));
  const Eigen::Vector3d first = leg.Position(0).head<3>();
  const Eigen::Vector3d last = leg.Position(leg.TotalDuration()).head<3>();
  const double met_s =
      std::min(SecondsBetween(departure_ns, met.conflict.time_ns), leg.TotalDuration());
  // Whether a body standing with its reference point at `p` keeps clear of that robot's way.
  const auto out_of_the_way = [&](const Eigen::Vector3d& p, double body_height_m) {
    VerticalExtent own;
    own.bottom_m = p.z() - traffic.body.reference_height_m;
    own.top_m = own.bottom_m + body_height_m;
    return std::all_of(
        passing.begin(), passing.end(), [&](const std::pair<Eigen::Vector3d, VerticalExtent>& q) {
          return (p - q.first).head<2>().norm() > clear_m || !ExtentsOverlap(own, q.second);
        });
  };
  for (double t = met_s; t > 0; t -= kStopSearchStepS) {
    // Each point may snap up to 2 * kStopSideOffsetsM.size() places beside the route.
    if (should_stop && should_stop()) return std::nullopt;
    const StateVector state = leg.Position(t);
    const Eigen::Vector3d on_route = state.head<3>();
    if ((on_route - first).norm() < kMinStopSpacingM) return std::nullopt;
    if ((on_route - last).norm() < kMinStopSpacingM) continue;
    const double body_height_m = state.size() > 3 ? state(3) : traffic.body.height_m;
    if (out_of_the_way(on_route, body_height_m)) return AddedStop{t, on_route};
    // Points beside the route: a bay off an aisle where the robot lets the other pass.
    const Eigen::Vector2d heading = leg.Velocity(t).head<2>();
    if (heading.norm() < 1e-6) continue;
    const Eigen::Vector3d side(-heading.y() / heading.norm(), heading.x() / heading.norm(), 0);
    for (const double side_m : kStopSideOffsetsM) {
      for (const double offset_m : {side_m, -side_m}) {
        const Eigen::Vector3d beside = on_route + offset_m * side;
        if (!out_of_the_way(beside, body_height_m)) continue;
        std::optional<Eigen::Vector3d> stand = stands(beside);
        if (stand && out_of_the_way(*stand, body_height_m)) return AddedStop{t, *stand};
      }
    }
  }
  return std::nullopt;
}

std::optional<Eigen::Vector3d> StandingPoint(const SurfaceGraph& graph,
                                             std::span<const KeepOutZone> zones,
                                             const RobotProfile& profile, int route_node,
                                             const Eigen::Vector3d& p) {
  const Expected<SnapResult> snapped =
      SnapEndpoint(graph, p, kStandingSnapM, ErrorCode::kGoalOffGround);
  if (!snapped || std::abs(snapped.value().position_m.z() - p.z()) > kStandingSnapM ||
      graph.component(snapped.value().node) != graph.component(route_node)) {
    return std::nullopt;
  }
  for (const KeepOutZone& zone : zones) {
    if (ViolatesKeepOut(zone.prism, profile, snapped.value().position_m)) return std::nullopt;
  }
  return snapped.value().position_m;
}

}  // namespace strata::fleet_internal
