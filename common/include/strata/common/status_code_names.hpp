#pragma once
/// The names of gRPC's canonical status codes (google/rpc/code.proto), by number, for the
/// server's errors and metrics and the client's messages alike, without depending on gRPC.
#include <string_view>

namespace strata::common {

/// One code's names: as the proto spells it ("INVALID_ARGUMENT"), and as Go's grpc package
/// prints it ("InvalidArgument", the grpc_code label of go-grpc-prometheus).
struct StatusCodeNames {
  std::string_view upper;
  std::string_view go;
};

/// Indexed by the code's number, 0 (OK) to 16 (UNAUTHENTICATED).
inline constexpr StatusCodeNames kStatusCodeNames[] = {
    {"OK", "OK"},
    {"CANCELLED", "Canceled"},
    {"UNKNOWN", "Unknown"},
    {"INVALID_ARGUMENT", "InvalidArgument"},
    {"DEADLINE_EXCEEDED", "DeadlineExceeded"},
    {"NOT_FOUND", "NotFound"},
    {"ALREADY_EXISTS", "AlreadyExists"},
    {"PERMISSION_DENIED", "PermissionDenied"},
    {"RESOURCE_EXHAUSTED", "ResourceExhausted"},
    {"FAILED_PRECONDITION", "FailedPrecondition"},
    {"ABORTED", "Aborted"},
    {"OUT_OF_RANGE", "OutOfRange"},
    {"UNIMPLEMENTED", "Unimplemented"},
    {"INTERNAL", "Internal"},
    {"UNAVAILABLE", "Unavailable"},
    {"DATA_LOSS", "DataLoss"},
    {"UNAUTHENTICATED", "Unauthenticated"},
};

/// The names of code `number`, or null for a number no canonical code has.
inline const StatusCodeNames* StatusCodeNamesOf(int number) {
  constexpr int kCount = static_cast<int>(sizeof kStatusCodeNames / sizeof kStatusCodeNames[0]);
  return number >= 0 && number < kCount ? &kStatusCodeNames[number] : nullptr;
}

}  // namespace strata::common
