#include "connection.hpp"

#include <fstream>
#include <iterator>

#include "strata/client/rpc.hpp"

namespace strata::cli {

std::shared_ptr<grpc::Channel> OpenChannel(const Context& ctx) {
  client::ChannelOptions options;
  if (!ctx.tls_ca.empty()) {
    std::ifstream in(ctx.tls_ca, std::ios::binary);
    options.tls_root_certs_pem.assign(std::istreambuf_iterator<char>(in),
                                      std::istreambuf_iterator<char>());
    if (options.tls_root_certs_pem.empty()) {
      throw UsageError("--tls-ca " + ctx.tls_ca + ": cannot read a PEM certificate there");
    }
  }
  return client::MakeChannel(ctx.server, options);
}

void PrepareCall(const Context& ctx, grpc::ClientContext* call, double deadline_s) {
  client::SetDeadline(call, deadline_s);
  client::SetToken(call, ctx.token);
}

}  // namespace strata::cli
