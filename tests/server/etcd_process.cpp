#include "etcd_process.hpp"

#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace strata::server::testing {
namespace {

constexpr const char* kEtcdBinary = "/usr/bin/etcd";

// A loopback port nothing listens on now (the kernel's choice for port 0).
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof(address);
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  close(fd);
  return port;
}

}  // namespace

std::unique_ptr<EtcdProcess> EtcdProcess::Start(const std::string& tls_cert,
                                                const std::string& tls_key) {
  if (access(kEtcdBinary, X_OK) != 0) {
    std::fprintf(stderr, "%s not found: install etcd-server (scripts/install-deps.sh)\n",
                 kEtcdBinary);
    return nullptr;
  }
  std::unique_ptr<EtcdProcess> etcd(new EtcdProcess());
  char pattern[] = "/tmp/strata-etcd-XXXXXX";
  if (mkdtemp(pattern) == nullptr) return nullptr;
  etcd->data_dir_ = pattern;
  etcd->tls_cert_ = tls_cert;
  etcd->tls_key_ = tls_key;
  etcd->client_port_ = FreePort();
  etcd->peer_port_ = FreePort();
  etcd->endpoint_ = "127.0.0.1:" + std::to_string(etcd->client_port_);
  if (!etcd->Launch()) return nullptr;
  return etcd;
}

bool EtcdProcess::Launch() {
  const std::string client_url = (tls_cert_.empty() ? "http://" : "https://") + endpoint_;
  const std::string peer_url = "http://127.0.0.1:" + std::to_string(peer_port_);
  std::vector<std::string> args = {kEtcdBinary,
                                   "--name=strata-test",
                                   "--data-dir=" + (data_dir_ / "data").string(),
                                   "--listen-client-urls=" + client_url,
                                   "--advertise-client-urls=" + client_url,
                                   "--listen-peer-urls=" + peer_url,
                                   "--initial-advertise-peer-urls=" + peer_url,
                                   "--initial-cluster=strata-test=" + peer_url};
  if (!tls_cert_.empty()) {
    args.push_back("--cert-file=" + tls_cert_);
    args.push_back("--key-file=" + tls_key_);
  }
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return false;
  {
    std::lock_guard lock(mutex_);
    ready_ = false;
    eof_ = false;
  }
  pid_ = fork();
  if (pid_ == 0) {
    // Dies with the test: a test that crashes must not leave it running, holding ctest's
    // output pipe open until the suite's timeout.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    dup2(fds[1], STDERR_FILENO);
    dup2(fds[1], STDOUT_FILENO);
    close(fds[0]);
    close(fds[1]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  if (reader_.joinable()) reader_.join();
  reader_ = std::thread([this, fd = fds[0]] { ReadLog(fd); });
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, std::chrono::seconds(30), [this] { return ready_ || eof_; });
  if (!ready_) std::fprintf(stderr, "etcd did not start; its log:\n%s\n", log_.c_str());
  return ready_;
}

void EtcdProcess::ReadLog(int fd) {
  char buffer[4096];
  for (ssize_t n; (n = read(fd, buffer, sizeof(buffer))) > 0;) {
    std::lock_guard lock(mutex_);
    log_.append(buffer, static_cast<std::size_t>(n));
    if (log_.find("ready to serve client requests") != std::string::npos) ready_ = true;
    changed_.notify_all();
  }
  close(fd);
  std::lock_guard lock(mutex_);
  eof_ = true;
  changed_.notify_all();
}

void EtcdProcess::Kill() {
  if (pid_ <= 0) return;
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
  pid_ = -1;
  if (reader_.joinable()) reader_.join();
  std::lock_guard lock(mutex_);
  log_.clear();  // Restart looks for its own "ready" line.
}

bool EtcdProcess::Restart() {
  Kill();
  return Launch();
}

std::string EtcdProcess::Log() const {
  std::lock_guard lock(mutex_);
  return log_;
}

EtcdProcess::~EtcdProcess() {
  Kill();
  std::error_code ignored;
  std::filesystem::remove_all(data_dir_, ignored);
}

}  // namespace strata::server::testing
