#include "rpc/rpc_boundary.hpp"

#include <new>

#include "common/log.hpp"
#include "rpc/error_mapping.hpp"
#include "rpc/metrics.hpp"

namespace strata::server {

ServiceError ErrorFromException(const std::exception_ptr& exception) {
  try {
    std::rethrow_exception(exception);
  } catch (const std::bad_alloc&) {
    return MakeError(ErrorCode::kResourceExhausted,
                     "the server ran out of memory handling this request");
  } catch (const std::exception& e) {
    return MakeError(ServiceErrorCode::kInternal,
                     std::string("internal error (a bug; please report it): ") + e.what());
  } catch (...) {
    return MakeError(ServiceErrorCode::kInternal,
                     "internal error (a bug; please report it): unknown exception");
  }
}

ServiceStatus AuthorizeCall(const RpcService& service, std::string_view rpc,
                            const grpc::ServerContext& context) {
  if (service.tokens == nullptr) return OkStatus();
  const auto& metadata = context.client_metadata();
  const auto found = metadata.find("authorization");
  const std::string_view value = found == metadata.end()
                                     ? std::string_view()
                                     : std::string_view(found->second.data(), found->second.size());
  return service.tokens->AuthorizeMethod(value,
                                         "/" + std::string(service.name) + "/" + std::string(rpc));
}

CallControl CallControlOf(const grpc::ServerContext& context) {
  CallControl call;
  const auto deadline = context.deadline();
  if (deadline != std::chrono::system_clock::time_point::max()) {
    call.deadline = std::chrono::steady_clock::now() +
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        deadline - std::chrono::system_clock::now());
  }
  call.cancelled = [&context] { return context.IsCancelled(); };
  const auto& metadata = context.client_metadata();
  if (const auto found = metadata.find("authorization"); found != metadata.end()) {
    call.authorization.assign(found->second.data(), found->second.size());
  }
  return call;
}

grpc::Status FinishRpc(std::string_view rpc, const CallLog& log, const ServiceStatus& outcome,
                       std::chrono::steady_clock::time_point start) noexcept {
  try {
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    grpc::Status status = grpc::Status::OK;
    LogLevel level = log.quiet_on_success ? LogLevel::kDebug : LogLevel::kInfo;
    std::string_view reason;
    if (!outcome.ok()) {
      const ErrorMapping mapping = MapError(outcome.error().code);
      reason = mapping.reason;
      status = ToGrpcStatus(outcome.error());
      const bool server_fault = mapping.grpc_code == grpc::StatusCode::INTERNAL ||
                                mapping.grpc_code == grpc::StatusCode::UNKNOWN;
      level = server_fault ? LogLevel::kError : LogLevel::kInfo;
    }
    if (LogEnabled(level)) {
      LogRecord record(level, "rpc");
      record.Add("rpc", rpc);
      if (!log.map_id.empty()) record.Add("map", log.map_id);
      record.Add("duration_ms", ms);
      record.Add("code", GoCodeName(status.error_code()));
      if (!outcome.ok()) {
        record.Add("reason", reason);
        record.Add("message", BoundedText(outcome.error().message, kMaxErrorMessageBytes));
      }
      for (const auto& [key, value] : log.fields) record.Add(key, value);
    }
    return status;
  } catch (...) {
    return grpc::Status(grpc::StatusCode::INTERNAL, "internal error while reporting an error");
  }
}

}  // namespace strata::server
