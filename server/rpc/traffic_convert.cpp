#include "rpc/traffic_convert.hpp"

#include <cmath>

#include <fmt/format.h>
#include <xxhash.h>

#include "rpc/proto_convert.hpp"

namespace strata::server {
namespace {

// The latest second a Timestamp may name: its nanoseconds since 1970 still fit an int64.
constexpr std::int64_t kMaxSeconds = 9'000'000'000;  // About the year 2255.

}  // namespace

Result<std::int64_t> FromProto(const google::protobuf::Timestamp& time, std::string_view field) {
  if (time.seconds() < 0 || time.seconds() > kMaxSeconds || time.nanos() < 0 ||
      time.nanos() >= 1'000'000'000) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("{} = {} s {} ns is not a time between 1970 and 2255 (seconds "
                                 "since 1970, nanos in [0, 1e9))",
                                 field, time.seconds(), time.nanos()))
        .Blame(std::string(field));
  }
  return time.seconds() * 1'000'000'000 + time.nanos();
}

void ToProto(std::int64_t time_ns, google::protobuf::Timestamp* time) {
  time->set_seconds(time_ns / 1'000'000'000);
  time->set_nanos(static_cast<int>(time_ns % 1'000'000'000));
}

Result<FleetBody> FromProto(const v1::FleetBody& message, std::string_view field) {
  FleetBody body;
  body.radius_m = message.radius_m();
  body.reference_height_m = message.reference_height_m();
  body.height_m = message.height_m();
  if (Status valid = body.Validate(field); !valid) {
    return ServiceError::FromPlanner(valid.error(), valid.error().field);
  }
  return body;
}

void ToProto(const FleetBody& body, v1::FleetBody* message) {
  message->set_radius_m(body.radius_m);
  message->set_reference_height_m(body.reference_height_m);
  message->set_height_m(body.height_m);
}

void ToProto(const Reservation& reservation, v1::Reservation* message) {
  const FleetMotion& motion = reservation.reserved.motion;
  message->set_map_id(reservation.map_id);
  message->set_map_version(reservation.map_version);
  message->set_robot_id(reservation.reserved.robot_id);
  ToProto(motion.start_ns, message->mutable_start_time());
  ToProto(motion.trajectory, message->mutable_trajectory());
  ToProto(motion.body, message->mutable_body());
  ToProto(motion.end_ns, message->mutable_expiry_time());
  message->set_revision(reservation.revision);
  message->set_follows_replans(reservation.replan_profile.has_value());
  message->set_replanned_for(reservation.replanned_for);
  message->set_separation_m(motion.separation_m);
}

Result<Reservation> FromProto(const v1::Reservation& message) {
  Reservation reservation;
  reservation.map_id = message.map_id();
  reservation.map_version = message.map_version();
  reservation.reserved.robot_id = message.robot_id();
  reservation.revision = message.revision();
  reservation.replanned_for = message.replanned_for();
  FleetMotion& motion = reservation.reserved.motion;
  Result<std::int64_t> start = FromProto(message.start_time(), "start_time");
  if (!start.ok()) return std::move(start).error();
  motion.start_ns = start.value();
  Result<std::int64_t> end = FromProto(message.expiry_time(), "expiry_time");
  if (!end.ok()) return std::move(end).error();
  motion.end_ns = end.value();
  Result<Trajectory> trajectory = FromProto(message.trajectory());
  if (!trajectory.ok()) return std::move(trajectory).error();
  motion.trajectory = std::move(trajectory).value();
  Result<FleetBody> body = FromProto(message.body(), "body");
  if (!body.ok()) return std::move(body).error();
  motion.body = body.value();
  motion.separation_m = message.separation_m();
  if (Status valid = motion.Validate("reservation"); !valid) {
    return ServiceError::FromPlanner(valid.error(), valid.error().field);
  }
  return reservation;
}

Result<SeparationRule> SeparationFrom(const std::optional<double>& separation_m,
                                      const ScheduleLimits& limits, std::string_view field) {
  SeparationRule rule;
  rule.separation_m = separation_m.value_or(limits.default_separation_m);
  if (!(std::isfinite(rule.separation_m) && rule.separation_m >= 0)) {
    return MakeError(ErrorCode::kInvalidConfig,
                     fmt::format("{} = {:g} is out of range: must be >= 0 and finite", field,
                                 rule.separation_m))
        .Blame(std::string(field));
  }
  return rule;
}

Caller CallerOf(const TokenTable* tokens, std::string_view authorization) {
  if (tokens == nullptr) return {.owner = "", .admin = true};
  return {.owner = fmt::format("{:016x}", XXH3_64bits(authorization.data(), authorization.size())),
          .admin = tokens->Authorize(authorization, Role::kAdmin).ok()};
}

}  // namespace strata::server
