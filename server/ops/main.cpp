// strata-server: serves Strata's gRPC API. See server/README.md.
#include <pthread.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <fmt/format.h>
#include <grpc/health/v1/health.pb.h>

#include "common/free_memory.hpp"
#include "common/log.hpp"
#include "ops/flags.hpp"
#include "ops/strata_server.hpp"

namespace {

using strata::server::FlagsOutcome;
using strata::server::LogError;
using strata::server::LogInfo;
using strata::server::LogWarning;

}  // namespace

int main(int argc, char** argv) {
  // Each new version of a map reuses the pages the last one freed, or faults its pages in
  // 2 MB at a time (common/free_memory.hpp).
  strata::server::RunWithHugePagesForLargeBlocks(argv);
  strata::server::KeepFreedMemoryForReuse();
  // SIGTERM and SIGINT are blocked in every thread (threads inherit the mask) and taken
  // synchronously by one thread below, so shutdown runs as ordinary code, not in a handler.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const FlagsOutcome flags = strata::server::ParseFlags(argc, argv);
  switch (flags.action) {
    case FlagsOutcome::Action::kHelp:
    case FlagsOutcome::Action::kVersion: std::fputs(flags.text.c_str(), stdout); return 0;
    case FlagsOutcome::Action::kError:
      std::fprintf(stderr, "strata-server: %s\n", flags.text.c_str());
      return 2;
    case FlagsOutcome::Action::kRun: break;
  }
  const strata::server::ServerConfig& config = flags.config;
  strata::server::SetLogLevel(config.log_level);

  // Links the generated grpc.health.v1 descriptors into the pool reflection serves, so
  // reflection-based clients (grpcurl, buf curl) can call the built-in health service.
  (void)grpc::health::v1::HealthCheckRequest::descriptor();

  auto started = strata::server::StrataServer::Start(config);
  if (!started.ok()) {
    LogError("start_failed").Add("message", started.error().message);
    std::fprintf(stderr, "strata-server: %s\n", started.error().message.c_str());
    return 1;
  }
  std::unique_ptr<strata::server::StrataServer> server = std::move(started).value();
  LogInfo("listening")
      .Add("address", server->address())
      .Add("metrics_port", server->metrics_port())
      .Add("http_port", server->http_port())
      .Add("message", "listening on " + server->address());
  if (server->http_port() >= 0) {
    const std::string host =
        config.http_address == "0.0.0.0" ? std::string("localhost") : config.http_address;
    LogInfo("viewer").Add("message",
                          fmt::format("web viewer on http://{}:{}/", host, server->http_port()));
  }

  std::thread signal_thread([&server, &signals, &config] {
    int signal_number = 0;
    sigwait(&signals, &signal_number);
    // An orchestrator's SIGTERM waits for load balancers to notice NOT_SERVING; a person's
    // Ctrl-C does not.
    const double delay_s = signal_number == SIGTERM ? config.drain_delay_s : 0.0;
    LogInfo("shutdown")
        .Add("signal", signal_number == SIGTERM ? "SIGTERM" : "SIGINT")
        .Add("drain_delay_s", delay_s)
        .Add("grace_s", config.shutdown_grace_s)
        .Add("message",
             "health NOT_SERVING; serving new calls for the drain delay, then "
             "draining in-flight calls");
    const auto seconds = [](double s) {
      return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(s));
    };
    server->Shutdown(seconds(delay_s), seconds(config.shutdown_grace_s));
    // A second signal while draining means "now".
    sigwait(&signals, &signal_number);
    LogWarning("forced_exit").Add("message", "second signal: exiting without draining");
    std::_Exit(1);
  });
  signal_thread.detach();

  server->Wait();
  if (!server->WaitAssessmentsIdle(std::chrono::seconds(2))) {
    // Its worker process dies with this one (map_worker_main.cpp); nothing else is left.
    LogWarning("stopped").Add("message", "exiting with a map assessment unfinished");
    std::_Exit(0);
  }
  if (config.exit_on_preload_failure && server->preload_failed()) {
    LogError("stopped").Add("message", "a preloaded map failed (--exit-on-preload-failure)");
    std::_Exit(1);
  }
  LogInfo("stopped").Add("message", "every call finished");
  // Everything a client can observe is done and the log is written (unbuffered). Skipping
  // the destructors saves the metrics HTTP server's stop, which waits out its 2 s poll.
  std::_Exit(0);
}
