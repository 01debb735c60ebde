#pragma once
/// What HttpServer serves: a request in, an answer out, without sockets. The viewer's page and
/// API (http_api.hpp) and the Prometheus scrape page (metrics_page.hpp) are handlers.
#include <string>
#include <utility>
#include <vector>

#include "common/call_control.hpp"

namespace strata::server {

/// One HTTP request, as a handler sees it.
struct HttpRequest {
  std::string method;         ///< "GET", "POST", ...
  std::string path;           ///< Decoded, without the query: "/api/strata.v1.MapService/GetMap".
  std::string authorization;  ///< The Authorization header; empty when absent.
  std::string body;           ///< Within the server's request limit (HttpServer enforces it).
};

/// The answer to send.
struct HttpResponse {
  int status = 200;
  std::string content_type;
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  ///< Besides the content type.
};

class HttpHandler {
 public:
  virtual ~HttpHandler() = default;
  /// Answers `request`; `call` carries its deadline and cancellation. Called on several
  /// threads at once; must not throw.
  virtual HttpResponse Handle(const HttpRequest& request, const CallControl& call) const = 0;
};

}  // namespace strata::server
