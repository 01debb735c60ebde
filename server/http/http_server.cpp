#include "http/http_server.hpp"

#include <microhttpd.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "common/log.hpp"
#include "http/http_api.hpp"  // RequestTooLarge

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

// libmicrohttpd's last message while a server starts (servers start one at a time), for the
// error.
std::mutex start_mutex;
std::string start_message;

// libmicrohttpd's own messages (a client that closed early, a malformed request) at debug
// level: a client can cause them at will.
void LogMessage(void* /*self*/, const char* format, va_list arguments) {
  char text[512];
  std::vsnprintf(text, sizeof text, format, arguments);
  std::string message(text);
  while (!message.empty() && message.back() == '\n') message.pop_back();
  LogRecord(LogLevel::kDebug, "http_server").Add("message", message);
  std::lock_guard lock(start_mutex);
  start_message = std::move(message);
}

// The address to bind: `host` resolved (an IPv4 result first) with `port`.
std::optional<sockaddr_storage> BindAddress(const std::string& host, int port,
                                            std::string* problem) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (const int error = getaddrinfo(host.c_str(), nullptr, &hints, &found); error != 0) {
    *problem = gai_strerror(error);
    return std::nullopt;
  }
  const addrinfo* chosen = found;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    if (a->ai_family == AF_INET) {
      chosen = a;
      break;
    }
  }
  sockaddr_storage address{};
  std::memcpy(&address, chosen->ai_addr, chosen->ai_addrlen);
  freeaddrinfo(found);
  if (address.ss_family == AF_INET) {
    reinterpret_cast<sockaddr_in*>(&address)->sin_port = htons(static_cast<std::uint16_t>(port));
  } else {
    reinterpret_cast<sockaddr_in6*>(&address)->sin6_port = htons(static_cast<std::uint16_t>(port));
  }
  return address;
}

MHD_Result Queue(MHD_Connection* connection, HttpResponse response) {
  // The body is handed over, not copied: a map's geometry runs to megabytes.
  auto* body = new std::string(std::move(response.body));
  MHD_Response* reply = MHD_create_response_from_buffer_with_free_callback_cls(
      body->size(), body->data(), [](void* owned) { delete static_cast<std::string*>(owned); },
      body);
  if (reply == nullptr) {
    delete body;
    return MHD_NO;
  }
  MHD_add_response_header(reply, MHD_HTTP_HEADER_CONTENT_TYPE, response.content_type.c_str());
  for (const auto& [name, value] : response.headers) {
    MHD_add_response_header(reply, name.c_str(), value.c_str());
  }
  const MHD_Result queued =
      MHD_queue_response(connection, static_cast<unsigned>(response.status), reply);
  MHD_destroy_response(reply);
  return queued;
}

HttpResponse ShuttingDown() {
  return HttpResponse{503,
                      "text/plain; charset=utf-8",
                      "the server is shutting down; retry on another replica\n",
                      {{"Connection", "close"}}};
}

HttpResponse Busy(const std::string& serves) {
  return HttpResponse{
      503,
      "text/plain; charset=utf-8",
      fmt::format("{} has {} requests waiting; retry shortly\n", serves, kHttpQueuedRequests),
      {{"Retry-After", "1"}}};
}

}  // namespace

/// One request, from its headers to its answer.
struct HttpServer::Exchange {
  HttpRequest request;
  SteadyClock::time_point headers_time = SteadyClock::now();
  bool too_large = false;                // The body passed the limit: what follows is discarded.
  bool answering = false;                // Handed to the threads; its connection is suspended.
  std::optional<HttpResponse> response;  // Set by the thread before it resumes the connection.
};

struct HttpServer::Callbacks {
  // Called when a request's headers are in, for each part of its body, and once it is whole
  // (then again after the answering thread resumes the connection).
  static MHD_Result OnRequest(void* data, MHD_Connection* connection, const char* url,
                              const char* method, const char* /*version*/, const char* upload_data,
                              std::size_t* upload_data_size, void** state) {
    auto* self = static_cast<HttpServer*>(data);
    auto* exchange = static_cast<Exchange*>(*state);
    if (exchange == nullptr) {
      exchange = new Exchange();
      *state = exchange;
      exchange->request.method = method != nullptr ? method : "";
      exchange->request.path = url != nullptr ? url : "";
      if (const char* authorization =
              MHD_lookup_connection_value(connection, MHD_HEADER_KIND, "Authorization")) {
        exchange->request.authorization = authorization;
      }
      // A body the Content-Length says is too large is refused before it is read.
      if (const char* length = MHD_lookup_connection_value(connection, MHD_HEADER_KIND,
                                                           MHD_HTTP_HEADER_CONTENT_LENGTH)) {
        if (std::strtoull(length, nullptr, 10) > self->max_body_bytes_) {
          return Queue(connection, RequestTooLarge(self->max_body_bytes_));
        }
      }
      return MHD_YES;
    }
    if (*upload_data_size > 0) {
      // A part of the body. No answer may be queued now (libmicrohttpd's rule): a request
      // that trickles in too long is dropped with its connection.
      if (std::chrono::duration<double>(SteadyClock::now() - exchange->headers_time).count() >
          kHttpMaxRequestReadS) {
        return MHD_NO;
      }
      std::string& body = exchange->request.body;
      if (!exchange->too_large && body.size() + *upload_data_size > self->max_body_bytes_) {
        exchange->too_large = true;
        std::string().swap(body);
      }
      if (!exchange->too_large) body.append(upload_data, *upload_data_size);
      *upload_data_size = 0;
      return MHD_YES;
    }
    if (exchange->too_large) return Queue(connection, RequestTooLarge(self->max_body_bytes_));
    if (exchange->response) return Queue(connection, std::move(*exchange->response));
    if (exchange->answering) return MHD_YES;  // Not resumed yet.
    {
      std::lock_guard lock(self->answering_mutex_);
      if (self->stopping_) return Queue(connection, ShuttingDown());
      ++self->answering_;
    }
    exchange->answering = true;
    // Suspended before it is handed over: the thread may resume it at once.
    MHD_suspend_connection(connection);
    const bool posted = self->threads_->Post([self, connection, exchange] {
      exchange->response = self->handler_->Handle(exchange->request, CallControl{});
      MHD_resume_connection(connection);
    });
    if (!posted) {
      exchange->response = Busy(self->serves_);
      MHD_resume_connection(connection);
    }
    return MHD_YES;
  }

  // Called once per request that OnRequest saw, however it ended.
  static void OnCompleted(void* data, MHD_Connection* /*connection*/, void** state,
                          MHD_RequestTerminationCode /*why*/) {
    auto* self = static_cast<HttpServer*>(data);
    auto* exchange = static_cast<Exchange*>(*state);
    if (exchange == nullptr) return;
    *state = nullptr;
    const bool answered = exchange->answering;
    delete exchange;
    if (!answered) return;
    {
      std::lock_guard lock(self->answering_mutex_);
      --self->answering_;
    }
    self->answering_changed_.notify_all();
  }
};

bool IsLoopbackAddress(const std::string& address) {
  return address == "localhost" || address.rfind("127.", 0) == 0;
}

Result<std::unique_ptr<HttpServer>> HttpServer::Start(const HttpServerOptions& options,
                                                      const HttpHandler* handler) {
  std::unique_ptr<HttpServer> self(new HttpServer());
  self->handler_ = handler;
  self->max_body_bytes_ = options.max_body_bytes;
  self->serves_ = options.serves;
  const std::string where = fmt::format("{}:{}", options.address, options.port);
  const auto fail = [&options, &where](const std::string& why) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("{}: cannot serve {} on {}: {}", options.flags, options.serves,
                                 where, BoundedText(why, 256)));
  };
  std::string problem;
  std::optional<sockaddr_storage> address = BindAddress(options.address, options.port, &problem);
  if (!address) return fail(problem);
  self->threads_ =
      std::make_unique<JobThreads>(kHttpThreads, kHttpThreadStackBytes, kHttpQueuedRequests);

  unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME |
                   MHD_USE_ERROR_LOG;
  if (address->ss_family == AF_INET6) flags |= MHD_USE_IPv6;
  {
    std::lock_guard lock(start_mutex);
    start_message.clear();
  }
  self->daemon_ = MHD_start_daemon(
      flags, static_cast<std::uint16_t>(options.port), nullptr, nullptr, &Callbacks::OnRequest,
      self.get(), MHD_OPTION_SOCK_ADDR, reinterpret_cast<sockaddr*>(&*address),
      MHD_OPTION_CONNECTION_LIMIT, kHttpMaxConnections, MHD_OPTION_PER_IP_CONNECTION_LIMIT,
      kHttpMaxConnectionsPerClient, MHD_OPTION_CONNECTION_TIMEOUT, kHttpIdleTimeoutS,
      MHD_OPTION_CONNECTION_MEMORY_LIMIT, kHttpConnectionMemoryBytes, MHD_OPTION_NOTIFY_COMPLETED,
      &Callbacks::OnCompleted, self.get(), MHD_OPTION_EXTERNAL_LOGGER, &LogMessage, self.get(),
      MHD_OPTION_END);
  if (self->daemon_ == nullptr) {
    std::lock_guard lock(start_mutex);
    return fail(start_message.empty() ? std::string("libmicrohttpd would not start")
                                      : start_message);
  }
  const MHD_DaemonInfo* bound = MHD_get_daemon_info(self->daemon_, MHD_DAEMON_INFO_BIND_PORT);
  self->port_ = bound != nullptr ? bound->port : options.port;
  return self;
}

HttpServer::~HttpServer() { Stop(); }

void HttpServer::Stop() {
  if (daemon_ == nullptr) return;
  listen_socket_ = MHD_quiesce_daemon(daemon_);
  {
    // Every suspended connection must be resumed before the daemon stops (libmicrohttpd's
    // rule); requests that arrive meanwhile are answered 503 at once.
    std::unique_lock lock(answering_mutex_);
    stopping_ = true;
    answering_changed_.wait(lock, [this] { return answering_ == 0; });
  }
  MHD_stop_daemon(daemon_);
  daemon_ = nullptr;
  if (listen_socket_ >= 0) close(listen_socket_);
  listen_socket_ = -1;
  threads_->Stop();
}

}  // namespace strata::server
