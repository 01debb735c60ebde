#pragma once
/// gRPC helpers for Strata clients (target strata::client_grpc; the trajectory library,
/// strata::client, needs no gRPC): a channel with sensible settings, deadlines, and the
/// richer error model (google.rpc.ErrorInfo, BadRequest) unpacked from a failed status.
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/grpcpp.h>

namespace strata::client {

/// Settings of a channel to strata-server.
struct ChannelOptions {
  /// Largest response accepted [bytes], > 0. Default 64 MiB (the server sends at most its
  /// --max-send-message-bytes, 16 MiB by default).
  int max_receive_message_bytes = 64 << 20;
  /// Keepalive ping period [s], >= 5 (the server refuses more frequent pings); 0 disables.
  /// Default 20 s, which notices a dead Wi-Fi link while a long call is in flight.
  int keepalive_time_s = 20;
  /// Time to wait for a ping's answer before the connection is dropped [s], > 0. Default 10.
  int keepalive_timeout_s = 10;
  /// TLS: the PEM root certificates the server's certificate must chain to. Empty: plaintext.
  std::string tls_root_certs_pem;
  /// Mutual TLS: this client's certificate chain and private key (PEM); empty: none.
  std::string tls_cert_chain_pem;
  std::string tls_private_key_pem;
};

/// A channel to `address` ("host:port"): TLS when options.tls_root_certs_pem is set,
/// plaintext otherwise.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options = {});

/// Sets the call's deadline `seconds` from now. Every call should have one.
void SetDeadline(grpc::ClientContext* context, double seconds);

/// Adds `authorization: Bearer TOKEN` to the call, for a server run with --auth-tokens;
/// nothing for an empty token.
void SetToken(grpc::ClientContext* context, const std::string& token);

/// A failed call, unpacked.
struct RpcError {
  grpc::StatusCode code = grpc::StatusCode::OK;
  std::string code_name;  ///< Canonical name, e.g. "NOT_FOUND".
  std::string message;    ///< The status message.
  std::string reason;     ///< google.rpc.ErrorInfo.reason, e.g. "MAP_NOT_FOUND"; may be empty.
  std::string domain;     ///< google.rpc.ErrorInfo.domain, "strata" for the server's errors.
  std::map<std::string, std::string> metadata;  ///< google.rpc.ErrorInfo.metadata.
  /// google.rpc.BadRequest field violations: (field path, description).
  std::vector<std::pair<std::string, std::string>> field_violations;
};

/// Unpacks code, message and the details the server packs into `grpc-status-details-bin`
/// (see proto/README.md, "Errors"). Details that are absent or unreadable leave the
/// corresponding fields empty (e.g. for DEADLINE_EXCEEDED set by gRPC itself).
RpcError DescribeStatus(const grpc::Status& status);

/// Canonical name of a status code, e.g. "DEADLINE_EXCEEDED"; "UNKNOWN_CODE_<n>" otherwise.
std::string StatusCodeName(grpc::StatusCode code);

}  // namespace strata::client
