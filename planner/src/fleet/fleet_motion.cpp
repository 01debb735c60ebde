#include "strata/fleet/fleet_motion.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planning/robot_profile.hpp"

namespace strata {
namespace {

Error InvalidField(std::string_view path, std::string_view field, const std::string& why) {
  std::string name = internal::FieldPath(path, field);
  return Error{ErrorCode::kInvalidInput, fmt::format("{} {}", name, why), std::move(name)};
}

Status ValidateTrajectory(const Trajectory& trajectory, std::string_view path) {
  if (trajectory.dimension != 3 && trajectory.dimension != 4) {
    return InvalidField(path, "dimension",
                        fmt::format("is {}; a trajectory has dimension 3 (x, y, z) or 4 (x, y, "
                                    "z, body height)",
                                    trajectory.dimension));
  }
  return trajectory.ValidatePieces(path, kMaxTrajectoryPieces);
}

}  // namespace

FleetBody FleetBody::FromProfile(const RobotProfile& profile) {
  FleetBody body;
  body.radius_m = profile.footprint_radius_m;
  body.reference_height_m = profile.reference_height_m;
  body.height_m = profile.MaxBodyHeight();
  return body;
}

Status FleetBody::Validate(std::string_view path) const {
  const auto positive = [&](std::string_view field, double value) -> Status {
    if (std::isfinite(value) && value > 0) return Status::Ok();
    return InvalidField(path, field, fmt::format("is {} m; it must be positive and finite", value));
  };
  if (Status s = positive("radius_m", radius_m); !s) return s;
  if (Status s = positive("reference_height_m", reference_height_m); !s) return s;
  return positive("height_m", height_m);
}

std::int64_t FleetMotion::ArrivalNs() const {
  return AddSeconds(start_ns, trajectory.TotalDuration());
}

StateVector FleetMotion::StateAt(std::int64_t time_ns) const {
  return trajectory.Evaluate(SecondsBetween(start_ns, std::clamp(time_ns, start_ns, end_ns)), 0);
}

Eigen::Vector3d FleetMotion::ReferencePointAt(std::int64_t time_ns) const {
  return StateAt(time_ns).head<3>();
}

VerticalExtent FleetMotion::ExtentAt(std::int64_t time_ns) const {
  const StateVector state = StateAt(time_ns);
  VerticalExtent extent;
  extent.bottom_m = state(2) - body.reference_height_m;
  extent.top_m = extent.bottom_m + (trajectory.dimension == 4 ? state(3) : body.height_m);
  return extent;
}

Status FleetMotion::Validate(std::string_view path) const {
  if (Status s = ValidateTrajectory(trajectory, internal::FieldPath(path, "trajectory")); !s) {
    return s;
  }
  if (Status s = body.Validate(internal::FieldPath(path, "body")); !s) return s;
  if (end_ns < ArrivalNs()) {
    return InvalidField(path, "end_ns",
                        fmt::format("is {:.3f} s before the trajectory ends; a motion lasts at "
                                    "least as long as its trajectory",
                                    SecondsBetween(end_ns, ArrivalNs())));
  }
  return Status::Ok();
}

double SecondsBetween(std::int64_t from_ns, std::int64_t to_ns) {
  return static_cast<double>(to_ns - from_ns) * 1e-9;
}

std::int64_t AddSeconds(std::int64_t time_ns, double seconds) {
  return time_ns + std::llround(seconds * 1e9);
}

}  // namespace strata
