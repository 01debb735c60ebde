#include "http/http_api.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <iterator>

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include "common/log.hpp"
#include "http/viewer_assets.hpp"
#include "rpc/error_mapping.hpp"
#include "rpc/rpc_boundary.hpp"

namespace strata::server {
namespace {

constexpr std::string_view kApiPrefix = "/api/";
// The page's own route to the same methods (http_api.hpp): every answer HTTP 200, the call's
// outcome in the body.
constexpr std::string_view kPageApiPrefix = "/viewer-api/";
constexpr const char* kJson = "application/json; charset=utf-8";

// The page loads only its own files and talks only to this server.
constexpr const char* kContentSecurityPolicy =
    "default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; "
    "connect-src 'self'; frame-ancestors 'none'";

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;     // The names of the .proto files and the docs.
  options.always_print_primitive_fields = true;  // Zeros too: level 0, a count of 0.
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

HttpResponse JsonResponse(int status, const google::protobuf::Message& message) {
  return HttpResponse{status, kJson, ToJson(message), {{"Cache-Control", "no-store"}}};
}

HttpResponse ErrorResponse(const ServiceError& error) {
  const google::rpc::Status status = ToRpcStatus(error);
  return JsonResponse(HttpStatusOf(static_cast<grpc::StatusCode>(status.code())), status);
}

// A failure of the HTTP exchange itself, which gRPC also reports without details (an unknown
// method, the wrong verb).
HttpResponse PlainError(int http_status, grpc::StatusCode code, std::string message) {
  google::rpc::Status status;
  status.set_code(static_cast<int>(code));
  status.set_message(std::move(message));
  return JsonResponse(http_status, status);
}

// Parses the body (protobuf's JSON mapping; empty = the empty message), runs `work` and
// answers its response or its error.
template <typename Request, typename Response, typename Work>
HttpResponse Call(const std::string& body, std::string* map_id, Work&& work) {
  Request request;
  if (!body.empty()) {
    google::protobuf::util::JsonParseOptions options;
    options.ignore_unknown_fields = false;  // A misspelt field is an error, not a default.
    if (const auto parsed = google::protobuf::util::JsonStringToMessage(body, &request, options);
        !parsed.ok()) {
      return ErrorResponse(MakeError(
          ErrorCode::kInvalidInput,
          "the body is not a " + Request::descriptor()->full_name() +
              " in protobuf's JSON mapping: " + BoundedText(std::string(parsed.message()), 256)));
    }
  }
  if constexpr (requires { request.map_id(); }) *map_id = BoundedText(request.map_id(), 64);
  Response response;
  ServiceStatus status = work(request, &response);
  if (!status.ok()) return ErrorResponse(status.error());
  return JsonResponse(200, response);
}

// The page route's answer for an API answer: HTTP 200 with {"response": <message>} or
// {"error": <google.rpc.Status>}, so that the browser logs no failed load for a refused call.
HttpResponse InBody(HttpResponse answer) {
  answer.body =
      fmt::format(R"({{"{}":{}}})", answer.status == 200 ? "response" : "error", answer.body);
  answer.status = 200;
  answer.content_type = kJson;
  return answer;
}

}  // namespace

int HttpStatusOf(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return 200;
    case grpc::StatusCode::CANCELLED: return 499;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE: return 400;
    case grpc::StatusCode::DEADLINE_EXCEEDED: return 504;
    case grpc::StatusCode::NOT_FOUND: return 404;
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::ABORTED: return 409;
    case grpc::StatusCode::PERMISSION_DENIED: return 403;
    case grpc::StatusCode::UNAUTHENTICATED: return 401;
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return 429;
    case grpc::StatusCode::UNIMPLEMENTED: return 501;
    case grpc::StatusCode::UNAVAILABLE: return 503;
    default: return 500;  // UNKNOWN, INTERNAL, DATA_LOSS.
  }
}

HttpResponse RequestTooLarge(std::size_t max_bytes) {
  return PlainError(413, grpc::StatusCode::RESOURCE_EXHAUSTED,
                    fmt::format("the request body is larger than {} bytes, the server's "
                                "--max-receive-message-bytes",
                                max_bytes));
}

HttpApi::HttpApi(const MapRegistry* registry, const MapServiceImpl* maps,
                 PlannerServiceImpl* planner, TrafficServiceImpl* traffic, const TokenTable* tokens)
    : registry_(registry), maps_(maps), planner_(planner), traffic_(traffic), tokens_(tokens) {}

HttpResponse HttpApi::Handle(const HttpRequest& request, const CallControl& call) const {
  const auto start = std::chrono::steady_clock::now();
  std::string method;
  std::string map_id;
  HttpResponse response;
  const bool page_route = request.path.rfind(kPageApiPrefix, 0) == 0;
  try {
    if (page_route || request.path.rfind(kApiPrefix, 0) == 0) {
      method = request.path.substr((page_route ? kPageApiPrefix : kApiPrefix).size());
      response = HandleApi(request, call, method, &map_id);
    } else {
      response = HttpResponse{404, "text/plain; charset=utf-8", "not found\n", {}};
      for (const ViewerAsset& asset : ViewerAssets()) {
        if (asset.path != request.path) continue;
        if (request.method != "GET" && request.method != "HEAD") {
          response =
              HttpResponse{405, "text/plain; charset=utf-8", "use GET\n", {{"Allow", "GET"}}};
          break;
        }
        response = HttpResponse{
            200,
            std::string(asset.content_type),
            std::string(asset.body),
            {{"Cache-Control", "no-cache"}, {"Content-Security-Policy", kContentSecurityPolicy}}};
        break;
      }
    }
  } catch (...) {
    response = ErrorResponse(ErrorFromException(std::current_exception()));
  }
  response.headers.emplace_back("X-Content-Type-Options", "nosniff");
  // One line per API call, as the gRPC boundary writes one per RPC; the page's files and
  // successful reads only at debug level (the viewer polls). Levels follow the call's outcome
  // on both routes.
  const int outcome = response.status;
  if (page_route) response = InBody(std::move(response));
  const bool quiet =
      method.empty() || (outcome == 200 && method != "strata.v1.PlannerService/Plan");
  LogRecord record(quiet ? LogLevel::kDebug : (outcome >= 500 ? LogLevel::kError : LogLevel::kInfo),
                   "http");
  record.Add("http_method", request.method);
  record.Add("path", request.path);
  if (!map_id.empty()) record.Add("map", map_id);
  record.Add("status", response.status);
  if (outcome != response.status) record.Add("outcome_status", outcome);
  record.Add(
      "duration_ms",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  return response;
}

HttpResponse HttpApi::HandleApi(const HttpRequest& request, const CallControl& transport_call,
                                std::string_view method, std::string* map_id) const {
  CallControl call = transport_call;
  call.authorization = request.authorization;
  if (request.method != "POST") {
    HttpResponse response = PlainError(405, grpc::StatusCode::UNIMPLEMENTED,
                                       "the API takes POST with the request message as JSON");
    response.headers.emplace_back("Allow", "POST");
    return response;
  }
  const std::string& body = request.body;
  // What the API serves: every method that changes no map.
  const struct {
    std::string_view method;
    std::function<HttpResponse()> answer;
  } served[] = {
      {"strata.v1.MapService/ListMaps",
       [&] {
         return Call<v1::ListMapsRequest, v1::ListMapsResponse>(
             body, map_id,
             [&](const auto& in, auto* out) { return ListMapsFrom(*registry_, in, out); });
       }},
      {"strata.v1.MapService/GetMap",
       [&] {
         return Call<v1::GetMapRequest, v1::Map>(body, map_id, [&](const auto& in, auto* out) {
           return GetMapFrom(*registry_, in, out);
         });
       }},
      {"strata.v1.MapService/GetMapGeometry",
       [&] {
         return Call<v1::GetMapGeometryRequest, v1::MapGeometry>(
             body, map_id,
             [&](const auto& in, auto* out) { return maps_->GetMapGeometry(in, call, out); });
       }},
      {"strata.v1.PlannerService/Plan",
       [&] {
         return Call<v1::PlanRequest, v1::PlanResponse>(
             body, map_id,
             [&](const auto& in, auto* out) { return planner_->PlanOne(in, call, "http", out); });
       }},
      {"strata.v1.TrafficService/ListReservations",
       [&] {
         return Call<v1::ListReservationsRequest, v1::ListReservationsResponse>(
             body, map_id, [&](const auto& in, auto* out) { return traffic_->List(in, out); });
       }},
      {"strata.v1.PlannerService/ListRecentPlans",
       [&] {
         return Call<v1::ListRecentPlansRequest, v1::ListRecentPlansResponse>(
             body, map_id,
             [&](const auto& in, auto* out) { return planner_->ListRecentPlans(in, out); });
       }},
  };
  const auto it = std::find_if(std::begin(served), std::end(served),
                               [&](const auto& entry) { return entry.method == method; });
  if (it == std::end(served)) {
    std::string names;
    for (const auto& entry : served)
      names += (names.empty() ? "" : ", ") + std::string(entry.method);
    return PlainError(404, grpc::StatusCode::UNIMPLEMENTED,
                      "no API method " + BoundedText(std::string(method), 128) +
                          ": the viewer's API serves " + names);
  }
  // The role the server's one table gives the method (rpc/auth.hpp), as over gRPC.
  if (tokens_ != nullptr) {
    if (ServiceStatus allowed =
            tokens_->AuthorizeMethod(request.authorization, "/" + std::string(method));
        !allowed.ok()) {
      return ErrorResponse(allowed.error());
    }
  }
  return it->answer();
}

}  // namespace strata::server
