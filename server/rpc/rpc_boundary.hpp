#pragma once
/// The boundary every RPC handler runs inside: it turns a ServiceError into a grpc::Status
/// with the richer error details, catches every exception (so no client ever sees gRPC's
/// "Unexpected error in RPC handling"), and writes one log line per call.
#include <chrono>
#include <exception>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include "common/service_error.hpp"
#include "rpc/auth.hpp"
#include "rpc/planning_slots.hpp"

namespace strata::server {

/// What a handler tells the log about its call.
struct CallLog {
  std::string map_id;
  /// Extra key=value pairs (e.g. "points").
  std::vector<std::pair<std::string, std::string>> fields;
  /// Successful calls of read-only rpcs (GetMap, ListMaps) log at debug level, so polling
  /// clients do not fill the log.
  bool quiet_on_success = false;
};

/// The ServiceError for an exception that escaped a handler body.
ServiceError ErrorFromException(const std::exception_ptr& exception);

/// Logs the call (rpc, map, duration, code, reason, and the message of failures) and
/// returns its grpc::Status. Never throws.
grpc::Status FinishRpc(std::string_view rpc, const CallLog& log, const ServiceStatus& outcome,
                       std::chrono::steady_clock::time_point start) noexcept;

/// A service as the boundary sees it: its full name ("strata.v1.MapService") and the tokens
/// its calls are checked against (null: every call is allowed).
struct RpcService {
  std::string_view name;
  const TokenTable* tokens = nullptr;
};

/// With `service.tokens` (--auth-tokens), the call's `authorization` metadata must hold a token
/// of the role kMethodRoles gives the method (TokenTable::AuthorizeMethod); without, every call
/// is allowed.
ServiceStatus AuthorizeCall(const RpcService& service, std::string_view rpc,
                            const grpc::ServerContext& context);

/// The call's deadline and cancellation, for work shared with other transports.
CallControl CallControlOf(const grpc::ServerContext& context);

/// Runs `body(CallLog&) -> ServiceStatus` inside the boundary for method `rpc` of `service`,
/// once the call is authorized (AuthorizeCall): no handler checks a role of its own.
template <typename Body>
grpc::Status RunRpc(const RpcService& service, std::string_view rpc,
                    const grpc::ServerContext& context, Body&& body) noexcept {
  const auto start = std::chrono::steady_clock::now();
  CallLog log;
  ServiceStatus outcome = OkStatus();
  try {
    outcome = AuthorizeCall(service, rpc, context);
    if (outcome.ok()) outcome = body(log);
  } catch (...) {
    outcome = ErrorFromException(std::current_exception());
  }
  return FinishRpc(rpc, log, outcome, start);
}

}  // namespace strata::server
