#include "server_process.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <future>
#include <regex>
#include <sstream>

#include <grpc/health/v1/health.grpc.pb.h>

namespace strata::server::testing {

std::unique_ptr<ServerProcess> ServerProcess::Start(const std::vector<std::string>& args,
                                                    std::chrono::seconds timeout) {
  std::vector<std::string> argv_strings = {STRATA_SERVER_BINARY};
  for (const auto& [flag, fallback] :
       {std::pair{"--listen", "127.0.0.1:0"}, std::pair{"--metrics-port", "0"}}) {
    if (std::find(args.begin(), args.end(), flag) == args.end()) {
      argv_strings.insert(argv_strings.end(), {flag, fallback});
    }
  }
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& arg : argv_strings) argv.push_back(arg.data());
  argv.push_back(nullptr);

  int fds[2];
  // Close-on-exec: no other server started by this test inherits this pipe.
  if (pipe2(fds, O_CLOEXEC) != 0) return nullptr;
  std::unique_ptr<ServerProcess> process(new ServerProcess());
  process->pid_ = fork();
  if (process->pid_ == 0) {
    // Dies with the test: a test that crashes must not leave it running, holding ctest's
    // output pipe open until the suite's timeout.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    dup2(fds[1], STDERR_FILENO);
    close(fds[0]);
    close(fds[1]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  process->reader_ = std::thread([p = process.get(), fd = fds[0]] { p->ReadStderr(fd); });

  std::unique_lock lock(process->mutex_);
  const bool listening = process->changed_.wait_for(
      lock, timeout, [&] { return !process->address_.empty() || process->eof_; });
  if (!listening || process->address_.empty()) {
    std::fprintf(stderr, "strata-server did not start; its log:\n%s\n", process->log_.c_str());
    return nullptr;
  }
  return process;
}

ServerProcess::~ServerProcess() {
  if (pid_ > 0 && !exited_) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  if (reader_.joinable()) reader_.join();
}

void ServerProcess::ReadStderr(int fd) {
  static const std::regex kListening(R"(address=([0-9.]+:[0-9]+) metrics_port=(-?[0-9]+))");
  char buffer[4096];
  std::string line;
  while (true) {
    const ssize_t n = read(fd, buffer, sizeof(buffer));
    if (n <= 0) break;
    std::lock_guard lock(mutex_);
    log_.append(buffer, static_cast<std::size_t>(n));
    std::smatch match;
    if (address_.empty() && std::regex_search(log_, match, kListening)) {
      address_ = match[1];
      metrics_port_ = std::stoi(match[2]);
      static const std::regex kHttp(R"(metrics_port=-?[0-9]+ http_port=(-?[0-9]+))");
      if (std::smatch http; std::regex_search(log_, http, kHttp)) http_port_ = std::stoi(http[1]);
    }
    changed_.notify_all();
  }
  close(fd);
  std::lock_guard lock(mutex_);
  eof_ = true;
  changed_.notify_all();
}

std::shared_ptr<grpc::Channel> ServerProcess::NewChannel() const {
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // A real connection per client.
  arguments.SetMaxReceiveMessageSize(64 << 20);
  return grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), arguments);
}

bool ServerProcess::WaitServing(std::chrono::seconds timeout) const {
  auto stub = grpc::health::v1::Health::NewStub(NewChannel());
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + timeout);
  grpc::health::v1::HealthCheckRequest request;
  auto reader = stub->Watch(&context, request);
  grpc::health::v1::HealthCheckResponse response;
  while (reader->Read(&response)) {
    if (response.status() == grpc::health::v1::HealthCheckResponse::SERVING) {
      context.TryCancel();
      reader->Finish();
      return true;
    }
  }
  reader->Finish();
  return false;
}

void ServerProcess::Signal(int signal_number) const { kill(pid_, signal_number); }

int ServerProcess::WaitExit(std::chrono::seconds timeout) {
  auto waiter = std::async(std::launch::async, [pid = pid_] {
    int status = 0;
    waitpid(pid, &status, 0);
    return status;
  });
  if (waiter.wait_for(timeout) != std::future_status::ready) {
    kill(pid_, SIGKILL);
    waiter.wait();
    exited_ = true;
    return -1;
  }
  exited_ = true;
  const int status = waiter.get();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string ServerProcess::Log() const {
  std::lock_guard lock(mutex_);
  return log_;
}

bool ServerProcess::WaitForLog(const std::string& text, std::chrono::seconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] {
    return log_.find(text) != std::string::npos || eof_;
  }) && log_.find(text) != std::string::npos;
}

namespace {

// Sends `request` to 127.0.0.1:port and reads the whole answer (HTTP/1.0: the server closes).
// A server that stays silent for 30 s fails the exchange rather than hang the test.
std::string Exchange(int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  const timeval patience{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &patience, sizeof patience);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string response;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    std::size_t sent = 0;
    while (sent < request.size()) {
      const ssize_t n = send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    char buffer[8192];
    ssize_t n = 0;
    while ((n = recv(fd, buffer, sizeof(buffer), 0)) > 0) response.append(buffer, n);
  }
  close(fd);
  return response;
}

}  // namespace

std::string HttpGet(int port, const std::string& path) {
  const std::string response =
      Exchange(port, "GET " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n");
  const std::size_t body = response.find("\r\n\r\n");
  return body == std::string::npos ? "" : response.substr(body + 4);
}

HttpReply HttpPost(int port, const std::string& path, const std::string& body,
                   const std::vector<std::string>& headers) {
  std::string request =
      "POST " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n";
  bool length_given = false;
  for (const std::string& header : headers) {
    request += header + "\r\n";
    length_given = length_given || header.rfind("Content-Length:", 0) == 0;
  }
  if (!length_given) request += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  return HttpExchange(port, request + "\r\n" + body);
}

HttpReply HttpExchange(int port, const std::string& request) {
  const std::string response = Exchange(port, request);
  HttpReply reply;
  if (response.rfind("HTTP/1.", 0) == 0 && response.size() > 12) {
    reply.status = std::atoi(response.c_str() + 9);
  }
  const std::size_t start = response.find("\r\n\r\n");
  if (start != std::string::npos) reply.body = response.substr(start + 4);
  return reply;
}

double MetricValue(const std::string& exposition, const std::string& metric,
                   const std::vector<std::string>& labels) {
  std::istringstream lines(exposition);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(metric, 0) != 0) continue;
    const char next = line.size() > metric.size() ? line[metric.size()] : '\0';
    if (next != '{' && next != ' ') continue;
    bool all = true;
    for (const std::string& label : labels) all = all && line.find(label) != std::string::npos;
    if (all) return std::stod(line.substr(line.rfind(' ') + 1));
  }
  return 0;
}

bool Eventually(const std::function<bool()>& check, std::chrono::steady_clock::duration timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!check()) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace strata::server::testing
