#pragma once
// A reservation as the server listed it, read back into the planner's types for its exact
// check (the fleet tests through the real server).
#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "strata/fleet/fleet_motion.hpp"
#include "strata/v1/traffic_service.pb.h"

namespace strata::server::testing {

inline FleetMotion MotionOf(const v1::Reservation& reservation) {
  FleetMotion motion;
  motion.start_ns = FromProto(reservation.start_time(), "start_time").value();
  motion.end_ns = FromProto(reservation.expiry_time(), "expiry_time").value();
  motion.trajectory = FromProto(reservation.trajectory()).value();
  motion.body = FromProto(reservation.body(), "body").value();
  return motion;
}

}  // namespace strata::server::testing
