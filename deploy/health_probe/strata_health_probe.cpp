// strata-health-probe: asks a gRPC server's standard health service (grpc.health.v1.Health/
// Check) whether it is SERVING. Exit 0 when SERVING, 1 otherwise (NOT_SERVING, unknown
// service, unreachable, deadline), 3 for bad arguments. Docker and podman read 0 as healthy
// and 1 as unhealthy (they reserve 2, hence 3 for usage errors).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include <grpc/health/v1/health.grpc.pb.h>
#include <grpcpp/grpcpp.h>
#include <CLI/CLI.hpp>

namespace {

constexpr int kServing = 0;
constexpr int kNotServing = 1;
constexpr int kUsage = 3;

/// Where strata-server listens when configured by $STRATA_LISTEN, seen from the same host.
std::string DefaultAddress() {
  if (const char* address = std::getenv("STRATA_HEALTH_ADDRESS"); address && *address) {
    return address;
  }
  const char* listen = std::getenv("STRATA_LISTEN");
  if (listen == nullptr || *listen == '\0') return "127.0.0.1:50051";
  const std::string text = listen;
  const std::size_t colon = text.rfind(':');
  if (colon == std::string::npos) return "127.0.0.1:50051";
  const std::string host = text.substr(0, colon);
  const std::string port = text.substr(colon + 1);
  const bool wildcard =
      host.empty() || host == "0.0.0.0" || host == "[::]" || host == "::" || host == "[::0]";
  return (wildcard ? std::string("127.0.0.1") : host) + ":" + port;
}

const char* StatusName(grpc::health::v1::HealthCheckResponse::ServingStatus status) {
  using Response = grpc::health::v1::HealthCheckResponse;
  switch (status) {
    case Response::SERVING: return "SERVING";
    case Response::NOT_SERVING: return "NOT_SERVING";
    case Response::SERVICE_UNKNOWN: return "SERVICE_UNKNOWN";
    default: return "UNKNOWN";
  }
}

// The probe; main only adds a last catch (a bad_alloc or a throwing gRPC setup): an exception
// escaping main would end the probe with SIGABRT, which Docker reads as neither 0 nor 1.
int Probe(int argc, char** argv) {
  std::string address;
  std::string service;
  double timeout_s = 3.0;
  CLI::App app(
      "Calls grpc.health.v1.Health/Check on ADDRESS (host:port, plaintext) and prints the "
      "status.",
      "strata-health-probe");
  app.footer(
      "Exit 0 when SERVING, 1 otherwise (NOT_SERVING, unknown service, unreachable, deadline "
      "exceeded), 3 for bad arguments (Docker reserves 2).");
  app.add_option("ADDRESS", address,
                 "default: $STRATA_HEALTH_ADDRESS, else 127.0.0.1 and the port of "
                 "$STRATA_LISTEN (strata-server's listen address; the host too unless it is a "
                 "wildcard such as 0.0.0.0 or [::]), else 127.0.0.1:50051");
  app.add_option("--service", service, "service to ask about; \"\" is the whole server")
      ->type_name("NAME")
      ->capture_default_str();
  app.add_option("--timeout-s", timeout_s, "deadline of the call in seconds")
      ->type_name("S")
      ->check(CLI::Range(1e-3, 3600.0))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);  // The help on stdout, exit 0.
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "strata-health-probe: %s (--help lists the options)\n", error.what());
    return kUsage;
  }
  if (address.empty()) address = DefaultAddress();

  auto stub = grpc::health::v1::Health::NewStub(
      grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::duration_cast<std::chrono::system_clock::duration>(
                           std::chrono::duration<double>(timeout_s)));
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  grpc::health::v1::HealthCheckResponse response;
  const grpc::Status status = stub->Check(&context, request, &response);
  const std::string shown = service.empty() ? "\"\"" : service;
  if (!status.ok()) {
    // NOT_FOUND is the health service's answer for a service it does not know.
    std::printf("%s %s: call failed: code %d: %s\n", address.c_str(), shown.c_str(),
                static_cast<int>(status.error_code()), status.error_message().c_str());
    return kNotServing;
  }
  std::printf("%s %s: %s\n", address.c_str(), shown.c_str(), StatusName(response.status()));
  return response.status() == grpc::health::v1::HealthCheckResponse::SERVING ? kServing
                                                                             : kNotServing;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Probe(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "strata-health-probe: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "strata-health-probe: unknown error\n");
  }
  return kNotServing;
}
