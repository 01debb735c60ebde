#include "rpc/error_mapping.hpp"

#include "strata/common/status_code_names.hpp"

#include <google/rpc/error_details.pb.h>

namespace strata::server {
namespace {

using grpc::StatusCode;
using SE = ServiceErrorCode;
using PE = ErrorCode;

// The rule: INVALID_ARGUMENT when changing the request fixes it whatever the server holds
// (including a start or goal off the ground: the position is what the client must change);
// FAILED_PRECONDITION when the request is fine but the map, as it is, cannot serve it (not
// active yet, assessed for another robot, start and goal not connected); retrying the same
// request is pointless for both. UNAVAILABLE only where retrying later may succeed.
const ErrorMapping kTable[] = {
    {PE::kInvalidInput, StatusCode::INVALID_ARGUMENT, "INVALID_INPUT"},
    {PE::kInvalidConfig, StatusCode::INVALID_ARGUMENT, "INVALID_CONFIG"},
    // A file that cannot be read as a point cloud, or a malformed upload stream.
    {PE::kMapLoadFailed, StatusCode::INVALID_ARGUMENT, "MAP_LOAD_FAILED"},
    {PE::kResourceExhausted, StatusCode::RESOURCE_EXHAUSTED, "RESOURCE_EXHAUSTED"},
    {PE::kStartOffGround, StatusCode::INVALID_ARGUMENT, "START_OFF_GROUND"},
    {PE::kGoalOffGround, StatusCode::INVALID_ARGUMENT, "GOAL_OFF_GROUND"},
    // Like off the ground: the start or goal is what the client must change (or its zone).
    {PE::kStartInKeepOut, StatusCode::INVALID_ARGUMENT, "START_IN_KEEP_OUT"},
    {PE::kGoalInKeepOut, StatusCode::INVALID_ARGUMENT, "GOAL_IN_KEEP_OUT"},
    {PE::kGoalUnreachable, StatusCode::FAILED_PRECONDITION, "GOAL_UNREACHABLE"},
    {PE::kNoPath, StatusCode::FAILED_PRECONDITION, "NO_PATH"},
    // The plan's own budget (the smaller of the client's and the server's) ran out. When the
    // client's deadline itself has passed, gRPC reports DEADLINE_EXCEEDED to it regardless.
    {PE::kDeadlineExceeded, StatusCode::DEADLINE_EXCEEDED, "TIME_BUDGET_EXCEEDED"},
    {PE::kCancelled, StatusCode::CANCELLED, "CANCELLED"},
    // The search's expansion budget: a server limit, like a quota.
    {PE::kSearchBudgetExhausted, StatusCode::RESOURCE_EXHAUSTED, "SEARCH_BUDGET_EXHAUSTED"},
    {PE::kProfileMismatch, StatusCode::FAILED_PRECONDITION, "PROFILE_MISMATCH"},
    // The optimiser ran, but its trajectory failed verification: not a server bug (INTERNAL)
    // and not the client's input as such; ABORTED says "this attempt did not succeed", and
    // the message names the violation (e.g. a speed bound) so the client can relax it.
    {PE::kOptimizationFailed, StatusCode::ABORTED, "OPTIMIZATION_FAILED"},
    // Another robot's committed trajectory is in the way: the schedule must change (a
    // reservation released or expired) before this plan can be made.
    {PE::kReservationConflict, StatusCode::FAILED_PRECONDITION, "RESERVATION_CONFLICT"},

    {SE::kMapNotFound, StatusCode::NOT_FOUND, "MAP_NOT_FOUND"},
    {SE::kMapNotActive, StatusCode::FAILED_PRECONDITION, "MAP_NOT_ACTIVE"},
    {SE::kMapAlreadyExists, StatusCode::ALREADY_EXISTS, "MAP_ALREADY_EXISTS"},
    {SE::kTooManyMaps, StatusCode::RESOURCE_EXHAUSTED, "TOO_MANY_MAPS"},
    // Not INVALID_ARGUMENT: the path may be well formed; this server will never serve it.
    {SE::kPathOutsideMapRoot, StatusCode::PERMISSION_DENIED, "PATH_OUTSIDE_MAP_ROOT"},
    {SE::kServerBusy, StatusCode::UNAVAILABLE, "SERVER_BUSY"},
    {SE::kShuttingDown, StatusCode::UNAVAILABLE, "SHUTTING_DOWN"},
    {SE::kInternal, StatusCode::INTERNAL, "INTERNAL"},
    {SE::kMapVersionNotFound, StatusCode::NOT_FOUND, "MAP_VERSION_NOT_FOUND"},
    // Another writer changed the map between the read and the write: redo the edit on the
    // current version.
    {SE::kMapChanged, StatusCode::ABORTED, "MAP_CHANGED"},
    // The shared volume failed (full, unmounted, an NFS outage): retrying later may succeed.
    {SE::kMapStoreUnavailable, StatusCode::UNAVAILABLE, "MAP_STORE_UNAVAILABLE"},
    // Stored bytes that fail their checksum or checks: the operator must repair the store.
    {SE::kMapCorrupted, StatusCode::DATA_LOSS, "MAP_CORRUPTED"},
    {SE::kMapStoreRequired, StatusCode::FAILED_PRECONDITION, "MAP_STORE_REQUIRED"},
    {SE::kEditNeedsCloud, StatusCode::FAILED_PRECONDITION, "EDIT_NEEDS_CLOUD"},
    {SE::kUnauthenticated, StatusCode::UNAUTHENTICATED, "UNAUTHENTICATED"},
    {SE::kPermissionDenied, StatusCode::PERMISSION_DENIED, "PERMISSION_DENIED"},
    {SE::kReservationNotFound, StatusCode::NOT_FOUND, "RESERVATION_NOT_FOUND"},
    // etcd is down or out of reach: plans that commit nothing are still answered.
    {SE::kSharedStateUnavailable, StatusCode::UNAVAILABLE, "SHARED_STATE_UNAVAILABLE"},
};

}  // namespace

std::span<const ErrorMapping> ErrorMappingTable() { return kTable; }

ErrorMapping MapError(const ServiceError::Code& code) {
  for (const ErrorMapping& row : kTable) {
    if (row.code == code) return row;
  }
  const auto* planner_code = std::get_if<ErrorCode>(&code);
  return {code, StatusCode::INTERNAL,
          planner_code != nullptr ? ErrorCodeName(*planner_code) : "INTERNAL"};
}

google::rpc::Status ToRpcStatus(const ServiceError& error) {
  const ErrorMapping mapping = MapError(error.code);
  google::rpc::ErrorInfo info;
  info.set_reason(std::string(mapping.reason));
  info.set_domain(std::string(kErrorDomain));
  for (const auto& [key, value] : error.metadata) {
    (*info.mutable_metadata())[BoundedText(key, kMaxErrorValueBytes)] =
        BoundedText(value, kMaxErrorValueBytes);
  }

  google::rpc::Status status;
  status.set_code(static_cast<int>(mapping.grpc_code));
  status.set_message(BoundedText(error.message, kMaxErrorMessageBytes));
  status.add_details()->PackFrom(info);
  if (!error.field_violations.empty()) {
    google::rpc::BadRequest bad_request;
    for (std::size_t i = 0; i < error.field_violations.size() && i < kMaxFieldViolations; ++i) {
      const FieldViolation& violation = error.field_violations[i];
      auto* v = bad_request.add_field_violations();
      v->set_field(BoundedText(violation.field, kMaxErrorValueBytes));
      v->set_description(BoundedText(violation.description, kMaxViolationDescriptionBytes));
    }
    status.add_details()->PackFrom(bad_request);
  }
  return status;
}

grpc::Status ToGrpcStatus(const ServiceError& error) {
  const google::rpc::Status status = ToRpcStatus(error);
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), status.message(),
                      status.SerializeAsString());
}

void ToProto(const ServiceError& error, v1::PlanError* message) {
  const ErrorMapping mapping = MapError(error.code);
  message->set_code(std::string(StatusCodeName(mapping.grpc_code)));
  message->set_reason(std::string(mapping.reason));
  message->set_message(BoundedText(error.message, kMaxErrorMessageBytes));
  for (const auto& [key, value] : error.metadata) {
    (*message->mutable_metadata())[BoundedText(key, kMaxErrorValueBytes)] =
        BoundedText(value, kMaxErrorValueBytes);
  }
}

std::string_view StatusCodeName(grpc::StatusCode code) {
  const common::StatusCodeNames* names = common::StatusCodeNamesOf(static_cast<int>(code));
  return names != nullptr ? names->upper : "UNKNOWN";
}

std::string_view GoCodeName(grpc::StatusCode code) {
  const common::StatusCodeNames* names = common::StatusCodeNamesOf(static_cast<int>(code));
  return names != nullptr ? names->go : "Unknown";
}

}  // namespace strata::server
