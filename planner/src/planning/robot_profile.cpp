#include "strata/planning/robot_profile.hpp"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"

namespace strata {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// Each component finite and within ±bound. A coordinate of 1e308 is finite, but no map
// reaches it, and a message quoting it in metres would print 300 digits.
Status CheckWithin(const Eigen::Vector3d& v, std::string_view path, double bound,
                   const char* unit) {
  for (int i = 0; i < 3; ++i) {
    if (std::abs(v(i)) <= bound) continue;  // False for NaN too.
    const std::string field = internal::FieldPath(path, std::string(1, "xyz"[i]));
    return Error{ErrorCode::kInvalidInput,
                 std::isfinite(v(i)) ? fmt::format("{} = {:g} {} is beyond ±{:g} {}", field, v(i),
                                                   unit, bound, unit)
                                     : fmt::format("{} must be finite, got {:g}", field, v(i)),
                 field};
  }
  return Status::Ok();
}

bool Positive(double v) { return std::isfinite(v) && v > 0; }

RobotProfile Differential() {
  RobotProfile p;
  p.name = "differential";
  return p;  // The defaults describe it.
}

RobotProfile Biped() {
  RobotProfile p;
  p.name = "biped";
  p.max_tilt_rad = 15.0 * kDegree;
  p.max_step_m = 0.1;
  p.reference_height_m = 0.2;
  p.active_height = true;
  p.body_height_m = 0.65;
  p.body_height_min_m = 0.35;
  p.body_height_max_m = 0.7;
  return p;
}

}  // namespace

Status RobotState::Validate(std::string_view path) const {
  if (Status s =
          CheckWithin(position_m, internal::FieldPath(path, "position_m"), kMaxAbsCoordinateM, "m");
      !s) {
    return s;
  }
  if (Status s = CheckWithin(velocity_mps, internal::FieldPath(path, "velocity_mps"), kMaxAbsMotion,
                             "m/s");
      !s) {
    return s;
  }
  return CheckWithin(acceleration_mps2, internal::FieldPath(path, "acceleration_mps2"),
                     kMaxAbsMotion, "m/s^2");
}

TraversabilityParams RobotProfile::Traversability() const { return TraversabilityParams(*this); }

Status TraversabilityParams::Validate(std::string_view path) const {
  const auto bad_param = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (!(std::isfinite(body_height_m) && body_height_m > 0)) {
    return bad_param("body_height_m", body_height_m, "> 0 and finite");
  }
  if (!(reference_height_m > 0 && reference_height_m <= body_height_m)) {
    return bad_param("reference_height_m", reference_height_m, "in (0, body_height_m]");
  }
  if (!(max_tilt_rad > 0 && max_tilt_rad < std::numbers::pi / 2)) {
    return bad_param("max_tilt_rad", max_tilt_rad, "in (0, pi/2)");
  }
  if (!(std::isfinite(max_step_m) && max_step_m >= 0)) {
    return bad_param("max_step_m", max_step_m, ">= 0 and finite");
  }
  return Status::Ok();
}

Status RobotProfile::Validate(std::string_view path) const {
  const auto bad_field = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (!Positive(footprint_radius_m))
    return bad_field("footprint_radius_m", footprint_radius_m, "> 0");
  if (!(max_tilt_rad > 0 && max_tilt_rad < std::numbers::pi / 2)) {
    return bad_field("max_tilt_rad", max_tilt_rad, "in (0, pi/2)");
  }
  if (!(std::isfinite(max_step_m) && max_step_m >= 0)) {
    return bad_field("max_step_m", max_step_m, ">= 0 and finite");
  }
  if (!Positive(reference_height_m)) {
    return bad_field("reference_height_m", reference_height_m, "> 0 and finite");
  }
  if (!Positive(max_speed_horizontal_mps)) {
    return bad_field("max_speed_horizontal_mps", max_speed_horizontal_mps, "> 0 and finite");
  }
  if (!Positive(max_speed_vertical_mps)) {
    return bad_field("max_speed_vertical_mps", max_speed_vertical_mps, "> 0 and finite");
  }
  if (!Positive(max_accel_horizontal_mps2)) {
    return bad_field("max_accel_horizontal_mps2", max_accel_horizontal_mps2, "> 0 and finite");
  }
  if (!Positive(max_accel_vertical_mps2)) {
    return bad_field("max_accel_vertical_mps2", max_accel_vertical_mps2, "> 0 and finite");
  }
  if (!(std::isfinite(headroom_m) && headroom_m >= 0)) {
    return bad_field("headroom_m", headroom_m, ">= 0 and finite");
  }
  if (!Positive(body_height_m)) return bad_field("body_height_m", body_height_m, "> 0 and finite");
  if (active_height) {
    if (!Positive(body_height_min_m)) {
      return bad_field("body_height_min_m", body_height_min_m, "> 0 and finite");
    }
    if (!(std::isfinite(body_height_max_m) && body_height_max_m >= body_height_min_m)) {
      return bad_field("body_height_max_m", body_height_max_m, ">= body_height_min_m");
    }
    if (!(body_height_m >= body_height_min_m && body_height_m <= body_height_max_m)) {
      return bad_field("body_height_m", body_height_m,
                       "in [body_height_min_m, body_height_max_m] (the preferred height)");
    }
  }
  if (reference_height_m > MinBodyHeight() + headroom_m) {
    return bad_field("reference_height_m", reference_height_m,
                     "at most the lowest body height + headroom_m");
  }
  return Status::Ok();
}

std::vector<std::string> BuiltinProfileNames() { return {"differential", "biped"}; }

Expected<RobotProfile> BuiltinProfile(const std::string& name) {
  if (name == "differential") return Differential();
  if (name == "biped") return Biped();
  return Error{ErrorCode::kInvalidInput, "unknown robot profile " + internal::Quote(name) +
                                             ": the built-in profiles are differential, biped"};
}

Status CheckProfileFitsMap(const RobotProfile& profile, const AssessmentConfig& assessment) {
  if (profile.footprint_radius_m > assessment.ground.radius_m) {
    return Error{ErrorCode::kProfileMismatch,
                 fmt::format("profile '{}' has footprint_radius_m = {:g} but the map was "
                             "assessed with ground.radius_m = {:g}: its valid ground may pass "
                             "too close to walls for this robot; assess the map with a ground "
                             "filter radius of at least {:g} m",
                             profile.name, profile.footprint_radius_m, assessment.ground.radius_m,
                             profile.footprint_radius_m),
                 "profile.footprint_radius_m"};
  }
  if (profile.max_tilt_rad > assessment.ground.max_tilt_rad + 1e-9) {
    return Error{
        ErrorCode::kProfileMismatch,
        fmt::format("profile '{}' has max_tilt_rad = {:g} ({:.1f} deg) but the map "
                    "was assessed with ground.max_tilt_rad = {:g} ({:.1f} deg): ground "
                    "the robot could climb was filtered out; assess the map with a max "
                    "tilt of at least {:.1f} deg",
                    profile.name, profile.max_tilt_rad, profile.max_tilt_rad / kDegree,
                    assessment.ground.max_tilt_rad, assessment.ground.max_tilt_rad / kDegree,
                    profile.max_tilt_rad / kDegree),
        "profile.max_tilt_rad"};
  }
  return Status::Ok();
}

}  // namespace strata
