#pragma once
/// Protobuf <-> the fleet's types: absolute times, bodies, reservations, and who a caller is.
#include <cstdint>
#include <string_view>

#include <google/protobuf/timestamp.pb.h>

#include "rpc/auth.hpp"
#include "strata/v1/traffic_service.pb.h"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

/// Nanoseconds since the Unix epoch of `time`, a time between 1970 and 2255; kInvalidInput
/// blaming `field` otherwise (nanos outside [0, 1e9) included).
Result<std::int64_t> FromProto(const google::protobuf::Timestamp& time, std::string_view field);
void ToProto(std::int64_t time_ns, google::protobuf::Timestamp* time);

/// kInvalidInput blaming `field`.<name> for a bad value (FleetBody::Validate).
Result<FleetBody> FromProto(const v1::FleetBody& body, std::string_view field);
void ToProto(const FleetBody& body, v1::FleetBody* message);

void ToProto(const Reservation& reservation, v1::Reservation* message);
/// The reservation `message` describes (as ToProto wrote it; the owner and the profile a robot
/// that follows replans is replanned with are not in it); kInvalidInput naming the first bad
/// field.
Result<Reservation> FromProto(const v1::Reservation& message);

/// The separation rule with `separation_m` (the server's default when unset); kInvalidConfig
/// blaming `field` when negative or not finite.
Result<SeparationRule> SeparationFrom(const std::optional<double>& separation_m,
                                      const ScheduleLimits& limits, std::string_view field);

/// Who the call's credentials (`authorization`, CallControl::authorization) make the caller:
/// without tokens, an admin nobody owns anything against; with them, the owner is a
/// fingerprint of the token (never the token itself) and admin its role.
Caller CallerOf(const TokenTable* tokens, std::string_view authorization);

}  // namespace strata::server
