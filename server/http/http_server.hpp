#pragma once
/// Serves an HttpHandler (the web viewer, the metrics page) over plain HTTP with GNU
/// libmicrohttpd. One event loop
/// (epoll) holds every connection, so a client that connects and says nothing, or sends its
/// request slowly, costs a socket and a few KiB, never a thread: it cannot keep the page from
/// anyone else. Connections are bounded in all and per client address; a connection silent
/// for kHttpIdleTimeoutS is closed; request line and headers fit in a fixed buffer; the body
/// is capped. A request, once read, is answered on JobThreads of this server's own, whose
/// stack size is set here (the work behind a call loads maps and plans, as a gRPC handler
/// does): the event loop never waits on it. No HTTP is parsed here.
///
/// No HTTPS: with TLS on the gRPC side, the server serves the viewer on loopback only
/// (strata_server.cpp), for a TLS-terminating proxy or an SSH tunnel.
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>

#include "common/job_threads.hpp"
#include "common/service_error.hpp"
#include "http/http_handler.hpp"

struct MHD_Daemon;
struct MHD_Connection;

namespace strata::server {

/// Threads that answer requests: API calls served at once; more wait in a queue of
/// kHttpQueuedRequests (then 503). Plans among them also wait for a planning slot, so this
/// bounds threads, not planning.
inline constexpr int kHttpThreads = 8;
inline constexpr std::size_t kHttpQueuedRequests = 64;
/// Stack of each answering thread [bytes]: what glibc gives a thread by default, and what the
/// gRPC handlers doing the same work run on.
inline constexpr std::size_t kHttpThreadStackBytes = std::size_t{8} << 20;
/// Connections held at once, in all and from one client address. A browser opens about six
/// to a server; past the limit a new connection is closed at once.
inline constexpr unsigned kHttpMaxConnections = 512;
inline constexpr unsigned kHttpMaxConnectionsPerClient = 32;
/// A connection that sends nothing for this long (between requests, or in the middle of one)
/// is closed [s]; a request left unfinished is never answered.
inline constexpr unsigned kHttpIdleTimeoutS = 10;
/// Longest a request may take to arrive once its headers are in [s]: a body that trickles in
/// longer is dropped with the connection.
inline constexpr double kHttpMaxRequestReadS = 30;
/// Memory of one connection for its request line, headers and read buffer [bytes]: a request
/// whose line and headers do not fit is answered 431 (or 414).
inline constexpr std::size_t kHttpConnectionMemoryBytes = 64 * 1024;

struct HttpServerOptions {
  /// Address (host name or IP address) and port; port 0 picks a free one (HttpServer::port).
  std::string address = "0.0.0.0";
  int port = 0;
  /// Largest request body accepted [bytes]; larger ones get 413, unread when the
  /// Content-Length says so, discarded as they arrive otherwise.
  std::size_t max_body_bytes = 0;
  /// What is served and the flags that place it, for messages: "cannot serve the viewer on
  /// ...", "the viewer has 64 requests waiting".
  std::string serves = "the viewer";
  std::string flags = "--http-address, --http-port";
};

/// Whether `address` (--http-address) only this machine reaches: 127.0.0.0/8 or "localhost".
bool IsLoopbackAddress(const std::string& address);

class HttpServer {
 public:
  /// Starts serving `handler` (which must outlive the server). Fails with kInvalidInput
  /// naming the flags and the problem (address in use, not a local address).
  static Result<std::unique_ptr<HttpServer>> Start(const HttpServerOptions& options,
                                                   const HttpHandler* handler);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// The port bound.
  int port() const { return port_; }

  /// Stops accepting, lets the requests being answered finish and send their answers, and
  /// closes every connection. Idempotent.
  void Stop();

 private:
  struct Exchange;
  struct Callbacks;  // libmicrohttpd's callbacks, in http_server.cpp.
  HttpServer() = default;

  const HttpHandler* handler_ = nullptr;
  std::size_t max_body_bytes_ = 0;
  std::string serves_;
  MHD_Daemon* daemon_ = nullptr;
  int listen_socket_ = -1;
  int port_ = 0;
  std::unique_ptr<JobThreads> threads_;
  // Requests handed to the threads and not yet answered: Stop waits for them.
  std::mutex answering_mutex_;
  std::condition_variable answering_changed_;
  int answering_ = 0;
  bool stopping_ = false;  // Under answering_mutex_: new requests get 503.
};

}  // namespace strata::server
