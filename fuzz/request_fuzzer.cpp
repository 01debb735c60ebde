// libFuzzer target: the request converters plan_request_fuzzer leaves out, as the services run
// them before touching a map. The first byte picks the request, the rest is its wire form:
//   0  UpdateMapRequest      → MapEditsFromProto (edits, keep-out zones)
//   1  PlanBatchRequest      → ParsePlanRequest on every item, as PlanBatch does
//   2  EstimateCostsRequest  → ParseEstimateCostsRequest
//   3  GetMapGeometryRequest → ProfileFromRequest
// Any request gives values or an error naming a field, and what is given holds what the
// converter promises.
#include <cstddef>
#include <cstdint>

#include "rpc/planner_service.hpp"
#include "rpc/proto_convert.hpp"
#include "strata/v1/map_service.pb.h"
#include "strata/v1/planner_service.pb.h"

namespace {

using namespace strata;          // NOLINT(google-build-using-namespace): a fuzz target's body.
using namespace strata::server;  // NOLINT(google-build-using-namespace)

template <typename Message>
bool Parse(const std::uint8_t* data, std::size_t size, Message* message) {
  return message->ParseFromArray(data, static_cast<int>(size));
}

// A converter that fails must say which field to fix.
void ExpectBlame(const ServiceError& error) {
  if (error.field_violations.empty() || error.message.empty()) __builtin_trap();
}

void UpdateMap(const std::uint8_t* data, std::size_t size) {
  v1::UpdateMapRequest request;
  if (!Parse(data, size, &request)) return;
  const Result<ParsedMapEdits> parsed = MapEditsFromProto(request);
  if (!parsed.ok()) return ExpectBlame(parsed.error());
  const std::size_t count = parsed->edits.size() + parsed->add_keep_out.size();
  if (count != static_cast<std::size_t>(request.edits_size()) ||
      count > static_cast<std::size_t>(kMaxMapEdits)) {
    __builtin_trap();
  }
  for (const MapEdit& edit : parsed->edits) {
    if (!edit.Validate("edit").ok()) __builtin_trap();
  }
  for (const Prism& zone : parsed->add_keep_out) {
    if (!zone.Validate("zone").ok()) __builtin_trap();
  }
}

void PlanBatch(const std::uint8_t* data, std::size_t size) {
  v1::PlanBatchRequest request;
  if (!Parse(data, size, &request)) return;
  for (const v1::PlanRequest& item : request.requests()) {
    const Result<ParsedPlanRequest> parsed = ParsePlanRequest(item);
    if (!parsed.ok()) {
      ExpectBlame(parsed.error());
      continue;
    }
    const PlanRequest& plan = parsed->plan;
    if (!plan.profile.Validate().ok() || !plan.options.Validate().ok() ||
        !plan.start.position_m.allFinite() || !plan.goal.position_m.allFinite()) {
      __builtin_trap();
    }
  }
}

void EstimateCosts(const std::uint8_t* data, std::size_t size) {
  v1::EstimateCostsRequest request;
  if (!Parse(data, size, &request)) return;
  constexpr int kMaxCells = 1000;
  const Result<ParsedCostRequest> parsed = ParseEstimateCostsRequest(request, kMaxCells);
  if (!parsed.ok()) return ExpectBlame(parsed.error());
  if (!parsed->profile.Validate().ok() ||
      parsed->starts_m.size() * parsed->goals_m.size() > static_cast<std::size_t>(kMaxCells)) {
    __builtin_trap();
  }
}

void GetMapGeometry(const std::uint8_t* data, std::size_t size) {
  v1::GetMapGeometryRequest request;
  if (!Parse(data, size, &request)) return;
  const Result<std::optional<RobotProfile>> profile = ProfileFromRequest(request);
  if (!profile.ok()) return ExpectBlame(profile.error());
  if (profile.value() && !profile.value()->Validate().ok()) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  switch (data[0] % 4) {
    case 0: UpdateMap(data + 1, size - 1); break;
    case 1: PlanBatch(data + 1, size - 1); break;
    case 2: EstimateCosts(data + 1, size - 1); break;
    default: GetMapGeometry(data + 1, size - 1); break;
  }
  return 0;
}
