#include "strata/fleet/map_change.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "strata/planning/keep_out.hpp"
#include "strata/planning/terrain_query.hpp"

namespace strata {
namespace {

// The profile a reservation's body stands for, as far as keep-out zones read one.
RobotProfile ProfileOf(const FleetBody& body) {
  RobotProfile profile;
  profile.footprint_radius_m = body.radius_m;
  profile.reference_height_m = body.reference_height_m;
  profile.body_height_m = body.height_m;
  profile.body_height_min_m = body.height_m;
  profile.body_height_max_m = body.height_m;
  return profile;
}

// What is wrong at reference point `p` on `map`, or empty.
std::string MapProblemAt(const PlanningMap& map, const std::vector<KeepOutZone>& zones,
                         const RobotProfile& profile, const VerifierConfig& config,
                         const Eigen::Vector3d& p) {
  const TerrainModel& model = map.model();
  const double distance = model.Distance(p);
  if (!(distance >= config.min_obstacle_distance_m)) {
    return fmt::format("an obstacle {:.3f} m from the reference point (at least {:.3f} m)",
                       distance, config.min_obstacle_distance_m);
  }
  GroundSample ground;
  if (!SampleGround(model, p, profile.reference_height_m, 0.0, &ground)) {
    return "no ground under the reference point";
  }
  const double tolerance =
      std::max(config.ground_tolerance_m, 0.75 * model.summary().vertical_quantum_m);
  const double offset = p.z() - profile.reference_height_m - ground.height_m;
  if (!(std::abs(offset) <= tolerance)) {
    return fmt::format(
        "the ground is {:.3f} m {} where the trajectory expects it (at most {:.3f} m)",
        std::abs(offset), offset > 0 ? "below" : "above", tolerance);
  }
  if (const int zone = FirstViolatedKeepOut(zones, profile, p); zone >= 0) {
    return "inside " + zones[static_cast<std::size_t>(zone)].name;
  }
  return {};
}

}  // namespace

std::optional<UnsafeMotion> FirstUnsafeOnMap(const PlanningMap& map, const FleetMotion& motion,
                                             std::int64_t from_ns, const VerifierConfig& config,
                                             double spacing_m) {
  const std::int64_t first_ns = std::max(from_ns, motion.start_ns);
  if (first_ns > motion.end_ns) return std::nullopt;
  const std::vector<KeepOutZone> zones = CollectKeepOut(map, {});
  const RobotProfile profile = ProfileOf(motion.body);
  // Times only move forward: a cursor keeps a long trajectory's walk linear.
  TrajectoryCursor cursor(motion.trajectory);
  const auto check = [&](std::int64_t time_ns) -> std::optional<UnsafeMotion> {
    const Eigen::Vector3d p =
        cursor.Position(SecondsBetween(motion.start_ns, std::min(time_ns, motion.end_ns)))
            .head<3>();
    std::string problem = MapProblemAt(map, zones, profile, config, p);
    if (problem.empty()) return std::nullopt;
    return UnsafeMotion{time_ns, p, std::move(problem)};
  };
  // Along the trajectory: a step of `spacing_m` at the speed of the moment (at most 0.5 s).
  const std::int64_t arrival_ns = motion.ArrivalNs();
  constexpr double kLongestStepS = 0.5;
  for (std::int64_t time_ns = first_ns; time_ns < arrival_ns;) {
    if (std::optional<UnsafeMotion> unsafe = check(time_ns)) return unsafe;
    const double t = SecondsBetween(motion.start_ns, time_ns);
    const double speed = cursor.Velocity(t).head<3>().norm();
    const double step_s = std::min(kLongestStepS, spacing_m / std::max(speed, 1e-3));
    time_ns = AddSeconds(time_ns, step_s);
  }
  // Parked at its end until the lease runs out.
  return check(std::max(first_ns, arrival_ns));
}

}  // namespace strata
