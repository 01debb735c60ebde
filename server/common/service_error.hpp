#pragma once
/// How failures travel inside the server (no gRPC here): a planner code (strata::ErrorCode)
/// or a code only the server knows, a message that says what to fix, the request fields at
/// fault, and machine-readable details. error_mapping.hpp turns one into a grpc::Status.
#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "strata/common/expected.hpp"
#include "strata/status.hpp"

namespace strata::server {

/// Failures the planner library cannot report because they concern the server's state.
enum class ServiceErrorCode {
  kMapNotFound,          ///< No map has the requested id.
  kMapNotActive,         ///< The map is CREATING or FAILED.
  kMapAlreadyExists,     ///< CreateMap with an id already in use (by a map not FAILED).
  kTooManyMaps,          ///< The server holds --max-maps maps.
  kPathOutsideMapRoot,   ///< A file path resolves outside --map-root (or there is no root).
  kServerBusy,           ///< Every planning slot stayed busy until the call's deadline.
  kShuttingDown,         ///< The server is draining for shutdown.
  kInternal,             ///< A bug: an exception reached a handler boundary.
  kMapVersionNotFound,   ///< The map exists but not the requested version (pruned, never put).
  kMapChanged,           ///< A compare-and-swap lost: the map's current version changed.
  kMapStoreUnavailable,  ///< The map store cannot be read or written (I/O error, full, gone).
  kMapCorrupted,         ///< A stored version or head fails its checks (truncated, tampered).
  kMapStoreRequired,     ///< The call needs a map store (--map-store) and the server has none.
  kEditNeedsCloud,       ///< UpdateMap on a map made from a saved model, which keeps no cloud.
  kUnauthenticated,      ///< The server needs a token and the call has none, or an unknown one.
  kPermissionDenied,     ///< The call's token has a role that may not make this call.
  kReservationNotFound,  ///< The robot holds no live reservation on the map.
  /// The shared state (etcd, --etcd) cannot be reached, or this replica's view of it is
  /// behind: nothing was changed.
  kSharedStateUnavailable,
};

/// Every ServiceErrorCode, for exhaustive tests.
inline constexpr ServiceErrorCode kAllServiceErrorCodes[] = {
    ServiceErrorCode::kMapNotFound,         ServiceErrorCode::kMapNotActive,
    ServiceErrorCode::kMapAlreadyExists,    ServiceErrorCode::kTooManyMaps,
    ServiceErrorCode::kPathOutsideMapRoot,  ServiceErrorCode::kServerBusy,
    ServiceErrorCode::kShuttingDown,        ServiceErrorCode::kInternal,
    ServiceErrorCode::kMapVersionNotFound,  ServiceErrorCode::kMapChanged,
    ServiceErrorCode::kMapStoreUnavailable, ServiceErrorCode::kMapCorrupted,
    ServiceErrorCode::kMapStoreRequired,    ServiceErrorCode::kEditNeedsCloud,
    ServiceErrorCode::kUnauthenticated,     ServiceErrorCode::kPermissionDenied,
    ServiceErrorCode::kReservationNotFound, ServiceErrorCode::kSharedStateUnavailable,
};

/// A request field that is wrong (google.rpc.BadRequest.FieldViolation). `field` is the
/// path in the request message, e.g. "start.position_m.x".
struct FieldViolation {
  std::string field;
  std::string description;
};

/// A failure anywhere in the server.
struct ServiceError {
  using Code = std::variant<ErrorCode, ServiceErrorCode>;

  Code code;
  std::string message;                           ///< What went wrong and what to do.
  std::vector<FieldViolation> field_violations;  ///< Request fields at fault, if any.
  std::map<std::string, std::string> metadata;   ///< ErrorInfo metadata, e.g. {"map_id", "x"}.

  /// A planner error, optionally blamed on one request field; its details become metadata.
  static ServiceError FromPlanner(const Error& error, std::string field = {});
  /// Adds a field violation whose description is the message; returns *this.
  ServiceError& Blame(std::string field);
  /// Adds one metadata entry; returns *this.
  ServiceError& With(std::string key, std::string value);
};

/// `text`, or its first bytes up to about `max_bytes` (whole UTF-8 characters) followed by
/// "…[N more bytes]": for text a client sent, quoted back in a message or a detail.
std::string BoundedText(std::string_view text, std::size_t max_bytes);

/// Shorthand for a server-side failure.
ServiceError MakeError(ServiceErrorCode code, std::string message);
/// Shorthand for a failure with a planner code.
ServiceError MakeError(ErrorCode code, std::string message);

/// A value or a ServiceError.
template <typename T>
using Result = common::Expected<T, ServiceError>;

/// Success, or a ServiceError, for calls without a value.
using ServiceStatus = common::Expected<void, ServiceError>;
inline ServiceStatus OkStatus() { return ServiceStatus::Ok(); }

}  // namespace strata::server
