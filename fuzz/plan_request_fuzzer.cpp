// libFuzzer target: a PlanRequest's conversion into the planner's types (server/
// proto_convert.hpp), as PlannerService does it before planning: the robot profile, the start
// and goal states, the options and the keep-out zones, each then validated. Any request gives
// values or an error naming a field; values that pass validation are finite.
#include <cstddef>
#include <cstdint>

#include "rpc/proto_convert.hpp"
#include "strata/v1/planner_service.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  strata::v1::PlanRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  using strata::server::FromProto;
  const auto profile = strata::server::ProfileFromRequest(request);
  if (profile.ok() && profile->Validate().ok()) {
    if (!(profile->max_speed_horizontal_mps > 0) || !(profile->footprint_radius_m > 0)) {
      __builtin_trap();
    }
  }
  for (const auto* state : {&request.start(), &request.goal()}) {
    const auto converted = FromProto(*state, "start");
    if (converted.ok() && converted->Validate("start").ok() && !converted->position_m.allFinite()) {
      __builtin_trap();
    }
  }
  const strata::PlanOptions options = FromProto(request.options());
  if (options.Validate().ok() && !(options.time_budget_s > 0)) __builtin_trap();
  const auto zones = strata::server::KeepOutFromRequest(request);
  if (zones.ok()) {
    for (const strata::Prism& zone : *zones) {
      if (!zone.Validate("keep_out").ok()) continue;
      // A valid zone contains the middle of its own box only if that is inside the polygon;
      // either way the question is answered without failing.
      (void)zone.Contains(zone.Bounds().center());
      if (!(zone.z_min_m <= zone.z_max_m)) __builtin_trap();
    }
  }
  return 0;
}
