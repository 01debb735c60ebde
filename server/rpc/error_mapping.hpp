#pragma once
/// The one table from failures (planner and server codes) to gRPC status codes and
/// google.rpc.ErrorInfo reasons, and the packing of a ServiceError into a grpc::Status with
/// the richer error model (google.rpc.Status in the binary details: ErrorInfo always,
/// BadRequest when fields are blamed).
#include <cstddef>
#include <span>
#include <string>
#include <string_view>

#include <google/rpc/status.pb.h>
#include <grpcpp/support/status.h>

#include "common/service_error.hpp"
#include "strata/v1/planner_service.pb.h"

namespace strata::server {

/// The most bytes of an error's message, of one ErrorInfo metadata value, and of one field
/// violation's description that reach a client (and the log); longer ones are cut with a
/// marker (BoundedText). A message may quote what the client sent (an id, a profile name, a
/// path): without a bound a 1 MiB name came back as a 1 MB message plus 2 MB of details, which
/// clients with the usual 8 KiB metadata limit see as RESOURCE_EXHAUSTED instead of the error.
/// With at most kMaxFieldViolations violations, the status and its details stay under 8 KiB.
inline constexpr std::size_t kMaxErrorMessageBytes = 1024;
inline constexpr std::size_t kMaxErrorValueBytes = 128;
inline constexpr std::size_t kMaxViolationDescriptionBytes = 256;
/// The most field violations one error carries.
inline constexpr std::size_t kMaxFieldViolations = 8;

/// ErrorInfo.domain of every Strata error.
inline constexpr std::string_view kErrorDomain = "strata";

/// One row of the table.
struct ErrorMapping {
  ServiceError::Code code;
  grpc::StatusCode grpc_code;
  std::string_view reason;  ///< UPPER_SNAKE_CASE, stable: clients switch on it.
};

/// The whole table, one row per planner and server code (see error_mapping.cpp for why each
/// code maps where it does; proto/README.md documents it for users).
std::span<const ErrorMapping> ErrorMappingTable();

/// The row of `code`. Codes missing from the table (a planner code added later) map to
/// INTERNAL with the planner's own name as the reason.
ErrorMapping MapError(const ServiceError::Code& code);

/// The google.rpc.Status of `error`: its code, message (cut, see kMaxErrorMessageBytes), and
/// details: an ErrorInfo always, a BadRequest when fields are blamed. What a gRPC client
/// receives in grpc-status-details-bin, a PlanBatch item's error, and the web viewer's JSON
/// API's error body.
google::rpc::Status ToRpcStatus(const ServiceError& error);

/// The grpc::Status for `error`: ToRpcStatus's code and message, and the whole google.rpc.Status
/// as its binary details.
grpc::Status ToGrpcStatus(const ServiceError& error);

/// The error as RecentPlan records it: the same code, reason, message and metadata.
void ToProto(const ServiceError& error, v1::PlanError* message);

/// The canonical name of a gRPC status code, e.g. "INVALID_ARGUMENT".
std::string_view StatusCodeName(grpc::StatusCode code);

/// The code's name as Go's grpc package prints it ("InvalidArgument"; "Unknown" for a code
/// that is none): the grpc_code label of go-grpc-prometheus's metrics.
std::string_view GoCodeName(grpc::StatusCode code);

}  // namespace strata::server
