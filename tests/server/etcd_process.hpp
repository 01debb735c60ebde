#pragma once
// Runs a real etcd (Debian's etcd-server, installed by scripts/install-deps.sh) for the tests
// of what replicas share: on free loopback ports, with a data directory of its own that
// outlives a kill, so that a test can stop etcd and start it again with everything it held.
#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace strata::server::testing {

class EtcdProcess {
 public:
  /// Starts etcd; null, with what went wrong printed, when there is no etcd or it is not
  /// ready to serve within 30 s. With `tls_cert` and `tls_key` (PEM files) it serves its
  /// clients over TLS only.
  static std::unique_ptr<EtcdProcess> Start(const std::string& tls_cert = {},
                                            const std::string& tls_key = {});
  ~EtcdProcess();  // Kills etcd and removes its data.

  /// "127.0.0.1:PORT", as --etcd takes it.
  const std::string& endpoint() const { return endpoint_; }

  /// Kills etcd with SIGKILL and waits for it: its clients find it unreachable.
  void Kill();
  /// Starts it again on the same ports with the same data; whether it became ready.
  bool Restart();

  std::string Log() const;

 private:
  EtcdProcess() = default;
  bool Launch();
  void ReadLog(int fd);

  std::filesystem::path data_dir_;
  std::string tls_cert_;
  std::string tls_key_;
  int client_port_ = 0;
  int peer_port_ = 0;
  std::string endpoint_;
  pid_t pid_ = -1;
  std::thread reader_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::string log_;
  bool ready_ = false;
  bool eof_ = false;
};

}  // namespace strata::server::testing
