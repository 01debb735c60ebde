#include "strata/fleet/fleet_motion.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

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
  return trajectory.Evaluate(TrajectoryTimeAt(time_ns), 0);
}

double FleetMotion::TrajectoryTimeAt(std::int64_t time_ns) const {
  return SecondsBetween(start_ns, std::clamp(time_ns, start_ns, end_ns));
}

Eigen::Vector3d FleetMotion::ReferencePointAt(std::int64_t time_ns) const {
  return StateAt(time_ns).head<3>();
}

VerticalExtent FleetMotion::ExtentAt(std::int64_t time_ns) const {
  return ExtentOf(StateAt(time_ns));
}

VerticalExtent FleetMotion::ExtentOf(const StateVector& state) const {
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
  if (!(std::isfinite(separation_m) && separation_m >= 0)) {
    return InvalidField(path, "separation_m",
                        fmt::format("is {:g}; must be finite and >= 0", separation_m));
  }
  return Status::Ok();
}

FleetMotion ContinuedBy(const FleetMotion& current, const FleetMotion& next, std::int64_t now_ns) {
  if (next.start_ns <= std::max(now_ns, current.start_ns) ||
      current.trajectory.dimension != next.trajectory.dimension) {
    return next;
  }
  // Times since current's start [s]. A piece cut shorter than this is left out: the next one
  // then starts a microsecond early, far below anything a robot or the check can tell.
  constexpr double kShortestPieceS = 1e-6;
  const double now_s = SecondsBetween(current.start_ns, now_ns);
  const double departure_s = SecondsBetween(current.start_ns, next.start_ns);
  std::vector<TrajectoryPiece> kept;
  double piece_start_s = 0;
  for (const TrajectoryPiece& piece : current.trajectory.pieces) {
    if (piece_start_s >= departure_s) break;
    const double piece_end_s = piece_start_s + piece.duration_s;
    const double duration_s = std::min(piece_end_s, departure_s) - piece_start_s;
    if (piece_end_s > now_s && duration_s >= kShortestPieceS) {
      kept.push_back(piece);
      kept.back().duration_s = duration_s;
    }
    piece_start_s = piece_end_s;
  }
  // Arrived before the departure: parked at its end until then (from now at the earliest).
  const double parked_s = departure_s - std::max(piece_start_s, now_s);
  if (parked_s >= kShortestPieceS) {
    kept.push_back(RestAt(current.StateAt(current.ArrivalNs()), parked_s));
  }
  if (kept.empty()) return next;

  FleetMotion joined = next;
  double kept_s = 0;
  for (const TrajectoryPiece& piece : kept) kept_s += piece.duration_s;
  joined.start_ns = AddSeconds(next.start_ns, -kept_s);
  joined.trajectory.pieces = std::move(kept);
  joined.trajectory.pieces.insert(joined.trajectory.pieces.end(), next.trajectory.pieces.begin(),
                                  next.trajectory.pieces.end());
  return joined;
}

TrajectoryPiece RestAt(const StateVector& state, double duration_s) {
  TrajectoryPiece rest;
  rest.duration_s = duration_s;
  rest.coefficients = Eigen::MatrixXd::Zero(6, state.size());
  rest.coefficients.row(0) = state.transpose();
  return rest;
}

double SecondsBetween(std::int64_t from_ns, std::int64_t to_ns) {
  return static_cast<double>(to_ns - from_ns) * 1e-9;
}

std::int64_t AddSeconds(std::int64_t time_ns, double seconds) {
  return time_ns + std::llround(seconds * 1e9);
}

}  // namespace strata
