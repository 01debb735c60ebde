#include "http_server.hpp"

#include <civetweb.h>

#include <iterator>
#include <mutex>
#include <utility>
#include <vector>

#include "log.hpp"

namespace strata::server {
namespace {

// civetweb's last message while a server starts (servers start one at a time), for the error.
std::mutex start_mutex;
std::string start_message;

// civetweb's own messages (a failed TLS handshake, a socket error) at debug level: a client
// can cause them at will.
int LogMessage(const mg_connection* /*connection*/, const char* message) {
  LogRecord(LogLevel::kDebug, "http_server").Add("message", message);
  std::lock_guard lock(start_mutex);
  start_message = message;
  return 1;  // Handled: civetweb prints nothing itself.
}

void Send(mg_connection* connection, const HttpResponse& response, bool head_only) {
  mg_response_header_start(connection, response.status);
  mg_response_header_add(connection, "Content-Type", response.content_type.c_str(), -1);
  const std::string length = std::to_string(response.body.size());
  mg_response_header_add(connection, "Content-Length", length.c_str(), -1);
  for (const auto& [name, value] : response.headers) {
    mg_response_header_add(connection, name.c_str(), value.c_str(), -1);
  }
  mg_response_header_send(connection);
  if (!head_only && !response.body.empty()) {
    mg_write(connection, response.body.data(), response.body.size());
  }
}

}  // namespace

bool IsLoopbackAddress(const std::string& address) {
  return address == "localhost" || address.rfind("127.", 0) == 0;
}

Result<std::unique_ptr<HttpServer>> HttpServer::Start(const HttpServerOptions& options,
                                                      const HttpApi* api) {
  std::unique_ptr<HttpServer> self(new HttpServer());
  self->api_ = api;
  self->max_body_bytes_ = options.max_body_bytes;
  // Counted, so calling it again is harmless. Never undone: prometheus-cpp's server in this
  // process shares the library.
  mg_init_library(0);
  const std::string where = options.address + ":" + std::to_string(options.port);
  const std::pair<const char*, std::string> settings[] = {
      {"listening_ports", where},
      {"num_threads", std::to_string(kHttpThreads)},
      {"connection_queue", std::to_string(kHttpConnectionQueue)},
      {"request_timeout_ms", std::to_string(kHttpSocketTimeoutMs)},
      // Request line and headers in a buffer of this size; larger ones are refused.
      {"max_request_size", std::to_string(kHttpMaxHeaderBytes)},
      // One request per connection: an idle keep-alive connection would hold a worker.
      {"enable_keep_alive", "no"},
  };
  std::vector<const char*> argv;
  argv.reserve(2 * std::size(settings) + 1);
  for (const auto& [name, value] : settings) {
    argv.push_back(name);
    argv.push_back(value.c_str());
  }
  argv.push_back(nullptr);
  mg_callbacks callbacks{};
  callbacks.log_message = LogMessage;
  {
    std::lock_guard lock(start_mutex);
    start_message.clear();
  }
  self->context_ = mg_start(&callbacks, self.get(), argv.data());
  if (self->context_ == nullptr) {
    std::lock_guard lock(start_mutex);
    return MakeError(ErrorCode::kInvalidInput,
                     "--http-address, --http-port: cannot serve the viewer on " + where + ": " +
                         (start_message.empty() ? std::string("civetweb would not start")
                                                : BoundedText(start_message, 256)));
  }
  mg_set_request_handler(self->context_, "/**", &HttpServer::HandleRequest, self.get());
  mg_server_port ports[4] = {};
  const int count = mg_get_server_ports(self->context_, 4, ports);
  self->port_ = count > 0 ? ports[0].port : options.port;
  return self;
}

HttpServer::~HttpServer() { Stop(); }

void HttpServer::Stop() {
  if (context_ != nullptr) {
    mg_stop(context_);
    context_ = nullptr;
  }
}

int HttpServer::HandleRequest(mg_connection* connection, void* data) {
  const auto* self = static_cast<const HttpServer*>(data);
  try {
    const mg_request_info* info = mg_get_request_info(connection);
    HttpRequest request;
    request.method = info->request_method != nullptr ? info->request_method : "";
    request.path = info->local_uri != nullptr ? info->local_uri : "";
    if (const char* authorization = mg_get_header(connection, "Authorization")) {
      request.authorization = authorization;
    }
    const bool head_only = request.method == "HEAD";
    // The body, never more than the limit: a larger one is refused before it is read (or,
    // without a Content-Length, as soon as it passes the limit).
    bool too_large = info->content_length > static_cast<long long>(self->max_body_bytes_);
    if (!too_large && info->content_length != 0) {
      char buffer[16384];
      int n = 0;
      while ((n = mg_read(connection, buffer, sizeof(buffer))) > 0) {
        request.body.append(buffer, static_cast<std::size_t>(n));
        if (request.body.size() > self->max_body_bytes_) {
          too_large = true;
          break;
        }
      }
    }
    if (too_large) {
      Send(connection, RequestTooLarge(self->max_body_bytes_), head_only);
      return 413;
    }
    // No deadline and no cancellation: an HTTP request is served as a gRPC call without a
    // deadline (plans within --max-plan-time-s).
    const HttpResponse response = self->api_->Handle(request, CallControl{});
    Send(connection, response, head_only);
    return response.status;
  } catch (...) {
    mg_send_http_error(connection, 500, "%s", "internal error");
    return 500;
  }
}

}  // namespace strata::server
