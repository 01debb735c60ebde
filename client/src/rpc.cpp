#include "strata/client/rpc.hpp"

#include "strata/common/status_code_names.hpp"

#include <chrono>

#include <google/rpc/error_details.pb.h>
#include <google/rpc/status.pb.h>

namespace strata::client {

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options) {
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(options.max_receive_message_bytes);
  if (options.keepalive_time_s > 0) {
    arguments.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, options.keepalive_time_s * 1000);
    arguments.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, options.keepalive_timeout_s * 1000);
    arguments.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 0);
  }
  if (options.tls_root_certs_pem.empty()) {
    return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments);
  }
  grpc::SslCredentialsOptions tls;
  tls.pem_root_certs = options.tls_root_certs_pem;
  tls.pem_cert_chain = options.tls_cert_chain_pem;
  tls.pem_private_key = options.tls_private_key_pem;
  return grpc::CreateCustomChannel(address, grpc::SslCredentials(tls), arguments);
}

void SetToken(grpc::ClientContext* context, const std::string& token) {
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
}

void SetDeadline(grpc::ClientContext* context, double seconds) {
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            std::chrono::duration<double>(seconds)));
}

std::string StatusCodeName(grpc::StatusCode code) {
  const common::StatusCodeNames* names = common::StatusCodeNamesOf(static_cast<int>(code));
  return names != nullptr ? std::string(names->upper)
                          : "UNKNOWN_CODE_" + std::to_string(static_cast<int>(code));
}

RpcError DescribeStatus(const grpc::Status& status) {
  RpcError error;
  error.code = status.error_code();
  error.code_name = StatusCodeName(status.error_code());
  error.message = status.error_message();
  google::rpc::Status details;
  if (status.error_details().empty() || !details.ParseFromString(status.error_details())) {
    return error;
  }
  for (const auto& detail : details.details()) {
    google::rpc::ErrorInfo info;
    google::rpc::BadRequest bad_request;
    if (detail.Is<google::rpc::ErrorInfo>() && detail.UnpackTo(&info)) {
      error.reason = info.reason();
      error.domain = info.domain();
      error.metadata.insert(info.metadata().begin(), info.metadata().end());
    } else if (detail.Is<google::rpc::BadRequest>() && detail.UnpackTo(&bad_request)) {
      for (const auto& violation : bad_request.field_violations()) {
        error.field_violations.emplace_back(violation.field(), violation.description());
      }
    }
  }
  return error;
}

}  // namespace strata::client
