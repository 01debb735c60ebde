#pragma once
// A reservation as the server listed it, read back into the planner's types for its exact
// check (the fleet tests through the real server).
#include <gtest/gtest.h>

#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "strata/fleet/fleet_motion.hpp"
#include "strata/v1/traffic_service.pb.h"

namespace strata::server::testing {

inline FleetMotion MotionOf(const v1::Reservation& reservation) {
  Result<Reservation> read = FromProto(reservation);
  EXPECT_TRUE(read.ok()) << read.error().message;
  return read.ok() ? read.value().reserved.motion : FleetMotion{};
}

}  // namespace strata::server::testing
