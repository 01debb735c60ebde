#pragma once
/// The one table from failures (planner and server codes) to gRPC status codes and
/// google.rpc.ErrorInfo reasons, and the packing of a ServiceError into a grpc::Status with
/// the richer error model (google.rpc.Status in the binary details: ErrorInfo always,
/// BadRequest when fields are blamed).
#include <span>
#include <string_view>

#include <grpcpp/support/status.h>

#include "service_error.hpp"

namespace strata::server {

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

/// The grpc::Status for `error`: its code, message, and details.
grpc::Status ToGrpcStatus(const ServiceError& error);

}  // namespace strata::server
