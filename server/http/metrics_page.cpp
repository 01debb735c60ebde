#include "http/metrics_page.hpp"

#include <exception>

#include "common/log.hpp"

namespace strata::server {
namespace {

// The content type of Prometheus' text exposition format.
constexpr const char* kExpositionType = "text/plain; version=0.0.4; charset=utf-8";
constexpr const char* kPlainType = "text/plain; charset=utf-8";

}  // namespace

HttpResponse MetricsPage::Handle(const HttpRequest& request, const CallControl& /*call*/) const {
  if (request.path != "/metrics") {
    return HttpResponse{404, kPlainType, "not found: the metrics are at /metrics\n", {}};
  }
  if (request.method != "GET" && request.method != "HEAD") {
    return HttpResponse{
        405, kPlainType, "/metrics answers GET (and HEAD) only\n", {{"Allow", "GET, HEAD"}}};
  }
  try {
    return HttpResponse{200, kExpositionType, metrics_->Serialize(), {}};
  } catch (const std::exception& e) {  // A collector's allocation failed, say.
    LogError("metrics_failed").Add("message", e.what());
    return HttpResponse{500, kPlainType, "the metrics could not be collected; retry\n", {}};
  }
}

}  // namespace strata::server
