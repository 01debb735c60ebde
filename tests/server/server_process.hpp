#pragma once
// Runs the real strata-server binary for integration tests: on 127.0.0.1 with ephemeral
// gRPC and metrics ports (read from its "listening" log line), its stderr collected.
#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

namespace strata::server::testing {

class ServerProcess {
 public:
  /// Starts the server with `args` after "--listen 127.0.0.1:0 --metrics-port 0" (each unless
  /// `args` sets it); returns null (and prints the log) if it does not report listening within
  /// `timeout`, or exits first.
  static std::unique_ptr<ServerProcess> Start(
      const std::vector<std::string>& args,
      std::chrono::seconds timeout = std::chrono::seconds(30));
  ~ServerProcess();  // Kills the server if it still runs.

  const std::string& address() const { return address_; }
  pid_t pid() const { return pid_; }
  int metrics_port() const { return metrics_port_; }
  /// The web viewer's port (-1 without --http-port).
  int http_port() const { return http_port_; }
  std::shared_ptr<grpc::Channel> NewChannel() const;

  /// Waits (health Watch, no polling) until the overall health status is SERVING.
  bool WaitServing(std::chrono::seconds timeout) const;

  void Signal(int signal_number) const;
  /// Waits for the process to exit: its exit code, or -1 on timeout or a signal death.
  int WaitExit(std::chrono::seconds timeout);

  /// Everything the server wrote to stderr so far.
  std::string Log() const;
  /// Waits until the log holds `text`; false after `timeout` or when the server exits.
  bool WaitForLog(const std::string& text, std::chrono::seconds timeout) const;

 private:
  ServerProcess() = default;
  void ReadStderr(int fd);

  pid_t pid_ = -1;
  bool exited_ = false;
  std::string address_;
  int metrics_port_ = -1;
  int http_port_ = -1;
  std::thread reader_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::string log_;
  bool eof_ = false;
};

/// GET http://127.0.0.1:port/path over a plain socket; the body, or "" on failure.
std::string HttpGet(int port, const std::string& path);

/// An HTTP exchange's answer: status (0 when there was none) and body.
struct HttpReply {
  int status = 0;
  std::string body;
};
/// Sends `request` (request line, headers and body, as they go on the wire) to
/// 127.0.0.1:port and reads the answer until the server closes (or stays silent for 30 s).
HttpReply HttpExchange(int port, const std::string& request);
/// POST `body` to http://127.0.0.1:port/path (HTTP/1.0, plain socket) with `headers` (each
/// "Name: value"; a Content-Length among them replaces the body's own).
HttpReply HttpPost(int port, const std::string& path, const std::string& body,
                   const std::vector<std::string>& headers = {});

/// Asks `check` every 10 ms until it holds or `timeout` passes; whether it held.
bool Eventually(const std::function<bool()>& check, std::chrono::steady_clock::duration timeout);

/// The value of the sample of `metric` whose labels contain every one of `labels` (each like
/// `grpc_method="Plan"`) in a Prometheus text exposition; 0 when there is none.
double MetricValue(const std::string& exposition, const std::string& metric,
                   const std::vector<std::string>& labels);

}  // namespace strata::server::testing
