#pragma once
/// The web viewer's side of strata-server, without sockets: its page (viewer_assets.hpp) and a
/// JSON API over the same service functions the gRPC handlers call, so the viewer shows
/// exactly what a gRPC client gets. http_server.hpp serves it over HTTP.
///
/// The API: `POST /api/<service>/<method>` with the method's request message in protobuf's
/// JSON mapping as the body (an empty body is the empty message), answering its response
/// message in the same mapping (field names as in the .proto, every field printed), for the
/// read-only methods and Plan:
///   strata.v1.MapService/ListMaps, strata.v1.MapService/GetMap,
///   strata.v1.MapService/GetMapGeometry, strata.v1.PlannerService/Plan,
///   strata.v1.PlannerService/ListRecentPlans.
/// A failure answers the google.rpc.Status a gRPC client would get (code, message, and the
/// ErrorInfo and BadRequest details, as JSON with "@type"), with the HTTP status Google's API
/// guidelines map its code to (INVALID_ARGUMENT 400, NOT_FOUND 404, UNAVAILABLE 503, ...).
/// The page itself calls the same methods at `POST /viewer-api/<service>/<method>`, where every
/// answer of the API is HTTP 200 with `{"response": <message>}` or `{"error": <Status>}` (as
/// JSON-RPC over HTTP does): a browser logs every 4xx/5xx as a failed load in its console, and
/// a refused plan is an answer the page shows, not a fault. Only the HTTP server's own refusals
/// (413, 503 busy or shutting down) keep their status there. The log line's `status` is what
/// was sent; on that route a failed call adds `outcome_status`, the status /api/ would send.
/// With --auth-tokens, every API call needs `Authorization: Bearer TOKEN` of role planner (or
/// admin); the page itself holds no data and needs none.
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "http/http_handler.hpp"
#include "rpc/auth.hpp"
#include "rpc/map_service.hpp"
#include "rpc/planner_service.hpp"
#include "rpc/planning_slots.hpp"
#include "rpc/traffic_service.hpp"

namespace strata::server {

/// The HTTP status that Google's API design guide maps a gRPC code to (google/rpc/code.proto).
int HttpStatusOf(grpc::StatusCode code);

/// 413, with the status gRPC answers a message above its limit with (RESOURCE_EXHAUSTED,
/// without details), naming the limit (--max-receive-message-bytes).
HttpResponse RequestTooLarge(std::size_t max_bytes);

class HttpApi : public HttpHandler {
 public:
  /// The services must outlive the API; `tokens` may be null (every call allowed).
  HttpApi(const MapRegistry* registry, const MapServiceImpl* maps, PlannerServiceImpl* planner,
          TrafficServiceImpl* traffic, const TokenTable* tokens);

  /// Answers `request` (the page's assets on GET, the API on POST), logging one line for an
  /// API call. `call` carries the request's deadline and cancellation. Thread-safe; never
  /// throws (an exception answers INTERNAL).
  HttpResponse Handle(const HttpRequest& request, const CallControl& call) const override;

 private:
  HttpResponse HandleApi(const HttpRequest& request, const CallControl& call,
                         std::string_view method, std::string* map_id) const;

  const MapRegistry* registry_;
  const MapServiceImpl* maps_;
  PlannerServiceImpl* planner_;
  TrafficServiceImpl* traffic_;
  const TokenTable* tokens_;
};

}  // namespace strata::server
