#pragma once
/// Prometheus' scrape page: `GET /metrics` answers Metrics::Serialize in the text exposition
/// format. Served by an HttpServer of its own on --metrics-address:--metrics-port, so the
/// metrics port has the viewer's protections against slow and hostile clients, and the
/// exposition holds only the series metrics.hpp lists (prometheus-cpp's Exposer added
/// exposer_* series, their latencies in microseconds).
#include "http/http_handler.hpp"
#include "rpc/metrics.hpp"

namespace strata::server {

class MetricsPage : public HttpHandler {
 public:
  /// `metrics` must outlive the page.
  explicit MetricsPage(const Metrics* metrics) : metrics_(metrics) {}

  /// GET or HEAD /metrics: 200 with the exposition; another path 404; another method 405.
  HttpResponse Handle(const HttpRequest& request, const CallControl& call) const override;

 private:
  const Metrics* metrics_;
};

}  // namespace strata::server
