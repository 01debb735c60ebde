// strata-health-probe: asks a gRPC server's standard health service (grpc.health.v1.Health/
// Check) whether it is SERVING. Exit 0 when SERVING, 1 otherwise (NOT_SERVING, unknown
// service, unreachable, deadline), 3 for bad arguments. Docker and podman read 0 as healthy
// and 1 as unhealthy (they reserve 2, hence 3 for usage errors).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <grpc/health/v1/health.grpc.pb.h>
#include <grpcpp/grpcpp.h>

namespace {

constexpr int kServing = 0;
constexpr int kNotServing = 1;
constexpr int kUsage = 3;

constexpr const char* kUsageText =
    "usage: strata-health-probe [ADDRESS] [--service NAME] [--timeout-s S]\n"
    "\n"
    "Calls grpc.health.v1.Health/Check on ADDRESS (host:port, plaintext) and prints the\n"
    "status. Exit 0 when SERVING, 1 otherwise (NOT_SERVING, unknown service, unreachable,\n"
    "deadline exceeded), 3 for bad arguments.\n"
    "\n"
    "  ADDRESS        default: $STRATA_HEALTH_ADDRESS, else 127.0.0.1 and the port of\n"
    "                 $STRATA_LISTEN (strata-server's listen address; the host too unless\n"
    "                 it is a wildcard such as 0.0.0.0 or [::]), else 127.0.0.1:50051\n"
    "  --service NAME service to ask about; default \"\" (the whole server)\n"
    "  --timeout-s S  deadline of the call in seconds, > 0; default 3\n";

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

}  // namespace

int main(int argc, char** argv) {
  std::string address;
  std::string service;
  double timeout_s = 3.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsageText, stdout);
      return kServing;
    }
    if (arg == "--service" || arg == "--timeout-s") {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "strata-health-probe: %s needs a value\n%s", arg.c_str(), kUsageText);
        return kUsage;
      }
      const std::string value = argv[++i];
      if (arg == "--service") {
        service = value;
      } else {
        char* end = nullptr;
        timeout_s = std::strtod(value.c_str(), &end);
        if (end == value.c_str() || *end != '\0' || !(timeout_s > 0.0) || timeout_s > 3600.0) {
          std::fprintf(stderr, "strata-health-probe: --timeout-s %s: want seconds in (0, 3600]\n",
                       value.c_str());
          return kUsage;
        }
      }
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr, "strata-health-probe: unknown flag %s\n%s", arg.c_str(), kUsageText);
      return kUsage;
    } else if (address.empty()) {
      address = arg;
    } else {
      std::fprintf(stderr, "strata-health-probe: one ADDRESS only (got %s)\n", arg.c_str());
      return kUsage;
    }
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
