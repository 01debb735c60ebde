#pragma once
// How every command reaches the server: the channel (--server, TLS with --tls-ca) and what
// each call carries (--deadline, --token).
#include <memory>

#include <grpcpp/grpcpp.h>

#include "context.hpp"

namespace strata::cli {

/// A channel to ctx.server: TLS trusting ctx.tls_ca when it is set (UsageError when the file
/// cannot be read), plaintext otherwise.
std::shared_ptr<grpc::Channel> OpenChannel(const Context& ctx);

/// Sets the call's deadline `deadline_s` from now and adds ctx.token.
void PrepareCall(const Context& ctx, grpc::ClientContext* call, double deadline_s);
inline void PrepareCall(const Context& ctx, grpc::ClientContext* call) {
  PrepareCall(ctx, call, ctx.deadline_s);
}

}  // namespace strata::cli
