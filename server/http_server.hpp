#pragma once
/// Serves an HttpApi (the web viewer) over plain HTTP with civetweb (libcivetweb, the embedded
/// server prometheus-cpp's /metrics already runs in this process): a fixed pool of worker
/// threads, a bounded queue of accepted connections, request headers in a fixed buffer,
/// socket timeouts, one request per connection, and a cap on the request body. No HTTP is
/// parsed here.
///
/// No HTTPS: bookworm's civetweb (1.15) is built against OpenSSL 1.1's API and loads
/// OpenSSL 3 at run time, and it crashes (SIGSEGV) on the first request over TLS; cpp-httplib
/// (0.11) serves TLS but reads request headers without bound. With TLS on the gRPC side, the
/// server therefore serves the viewer on loopback only (strata_server.cpp), for a
/// TLS-terminating proxy or an SSH tunnel.
#include <cstddef>
#include <memory>
#include <string>

#include "http_api.hpp"
#include "service_error.hpp"

struct mg_context;
struct mg_connection;

namespace strata::server {

/// Worker threads: requests served at once; more wait in the connection queue. Plans among
/// them also wait for a planning slot, so this bounds threads, not planning.
inline constexpr int kHttpThreads = 8;
/// Accepted connections waiting for a worker; beyond them the kernel's listen backlog holds
/// new ones.
inline constexpr int kHttpConnectionQueue = 32;
/// Longest a socket read or write may block [ms]: a client that stalls mid-request or stops
/// reading its answer frees its worker after this.
inline constexpr int kHttpSocketTimeoutMs = 10000;
/// Most bytes of a request line and headers [bytes]: the buffer civetweb reads them into.
inline constexpr int kHttpMaxHeaderBytes = 16384;

struct HttpServerOptions {
  /// Address (host or IPv4) and port; port 0 picks a free one (HttpServer::port).
  std::string address = "0.0.0.0";
  int port = 0;
  /// Largest request body accepted [bytes]; larger ones get 413 before they are read.
  std::size_t max_body_bytes = 0;
};

/// Whether `address` (--http-address) only this machine reaches: 127.0.0.0/8 or "localhost".
bool IsLoopbackAddress(const std::string& address);

class HttpServer {
 public:
  /// Starts serving `api` (which must outlive the server). Fails with kInvalidInput naming
  /// the problem (address in use, not a local address).
  static Result<std::unique_ptr<HttpServer>> Start(const HttpServerOptions& options,
                                                   const HttpApi* api);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// The port bound.
  int port() const { return port_; }

  /// Stops accepting and waits for the requests being served to end. Idempotent.
  void Stop();

 private:
  HttpServer() = default;
  static int HandleRequest(mg_connection* connection, void* self);

  const HttpApi* api_ = nullptr;
  std::size_t max_body_bytes_ = 0;
  mg_context* context_ = nullptr;
  int port_ = 0;
};

}  // namespace strata::server
