// The web viewer of a real strata-server (--http-port): off by default; its JSON answers what
// a gRPC client gets for the same request; it refuses bodies above the request limit, stays on
// loopback when gRPC has TLS, and stops with the server.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>

#include "http/http_server.hpp"
#include "server_fixture.hpp"
#include "test_util/run_command.hpp"

namespace strata::server::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

class ServerHttpTest : public ServerFixture {};

template <typename Message>
Message FromJson(const std::string& json) {
  Message message;
  const auto parsed = google::protobuf::util::JsonStringToMessage(json, &message);
  EXPECT_TRUE(parsed.ok()) << parsed.message() << ": " << json.substr(0, 300);
  return message;
}

std::string ToJson(const google::protobuf::Message& message) {
  std::string json;
  EXPECT_TRUE(google::protobuf::util::MessageToJsonString(message, &json).ok());
  return json;
}

TEST_F(ServerHttpTest, TheViewerIsOffByDefault) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  EXPECT_EQ(server_->http_port(), -1);
  EXPECT_THAT(server_->Log(), Not(HasSubstr("web viewer on")));
}

TEST_F(ServerHttpTest, ItsJsonIsWhatAGrpcClientGets) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--http-port", "0"}));
  const int port = server_->http_port();
  ASSERT_GT(port, 0);
  EXPECT_THAT(server_->Log(), HasSubstr("web viewer on http://localhost:" + std::to_string(port)));
  EXPECT_THAT(HttpGet(port, "/"), HasSubstr("<title>Strata viewer</title>"));

  v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  request.mutable_options()->set_time_budget_s(30);
  request.mutable_options()->set_return_search_path(true);
  v1::PlanResponse over_grpc;
  const grpc::Status status = Plan(request, &over_grpc);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const HttpReply reply = HttpPost(port, "/api/strata.v1.PlannerService/Plan", ToJson(request));
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const auto over_http = FromJson<v1::PlanResponse>(reply.body);
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(over_http.trajectory(),
                                                                 over_grpc.trajectory()));
  EXPECT_EQ(over_http.stats().length_m(), over_grpc.stats().length_m());
  EXPECT_EQ(over_http.search_path_m_size(), over_grpc.search_path_m_size());
  EXPECT_GT(over_grpc.search_path_m_size(), 1);

  // The geometry, a new RPC, alike over both.
  v1::GetMapGeometryRequest geometry_request;
  geometry_request.set_map_id("demo");
  geometry_request.set_include_safety(true);
  v1::MapGeometry over_grpc_geometry;
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  ASSERT_TRUE(maps_->GetMapGeometry(&context, geometry_request, &over_grpc_geometry).ok());
  const HttpReply geometry =
      HttpPost(port, "/api/strata.v1.MapService/GetMapGeometry", ToJson(geometry_request));
  ASSERT_EQ(geometry.status, 200);
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(
      FromJson<v1::MapGeometry>(geometry.body), over_grpc_geometry));
  EXPECT_GT(over_grpc_geometry.ground_z_m_size(), 1000);

  // The recent plans, over gRPC, hold the plan the viewer's API answered, newest first.
  v1::ListRecentPlansRequest recent_request;
  v1::ListRecentPlansResponse recent;
  grpc::ClientContext recent_context;
  SetDeadline(&recent_context, 10);
  ASSERT_TRUE(planner_->ListRecentPlans(&recent_context, recent_request, &recent).ok());
  ASSERT_GE(recent.plans_size(), 2);
  EXPECT_EQ(recent.plans(0).transport(), "http");
  EXPECT_EQ(recent.plans(1).transport(), "grpc");
}

TEST_F(ServerHttpTest, BodiesAboveTheRequestLimitAreRefusedUnread) {
  ASSERT_NO_FATAL_FAILURE(
      StartServer({"--http-port", "0", "--max-receive-message-bytes", "1114112"}));
  const HttpReply reply = HttpPost(server_->http_port(), "/api/strata.v1.MapService/ListMaps", "{}",
                                   {"Content-Length: 50000000"});
  EXPECT_EQ(reply.status, 413);
  EXPECT_THAT(reply.body, HasSubstr("--max-receive-message-bytes"));
  // And the server carries on.
  EXPECT_EQ(HttpPost(server_->http_port(), "/api/strata.v1.MapService/ListMaps", "{}").status, 200);
}

// With a map store, GetMap through the viewer's API loads the map's stored description on the
// thread that answers; on civetweb's 100 KiB stacks that overran after a few calls (the viewer
// went silent, once the server died). The API now answers on threads with a stack of a size
// set in http_server.hpp; this runs under AddressSanitizer in CI.
TEST_F(ServerHttpTest, TheApiAnswersCallAfterCallWithAMapStore) {
  const fs::path store =
      fs::temp_directory_path() / ("strata_http_store_" + std::to_string(getpid()));
  fs::remove_all(store);
  ASSERT_NO_FATAL_FAILURE(StartServer({"--http-port", "0", "--map-store", store.string()}));
  const int port = server_->http_port();
  v1::PlanRequest plan = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  plan.mutable_options()->set_time_budget_s(30);
  for (int i = 0; i < 20; ++i) {
    const HttpReply map =
        HttpPost(port, "/api/strata.v1.MapService/GetMap", R"({"map_id":"demo"})");
    ASSERT_EQ(map.status, 200) << "call " << i << ": " << map.body.substr(0, 300);
    EXPECT_EQ(FromJson<v1::Map>(map.body).state(), v1::MAP_STATE_ACTIVE);
    const HttpReply geometry =
        HttpPost(port, "/api/strata.v1.MapService/GetMapGeometry", R"({"map_id":"demo"})");
    ASSERT_EQ(geometry.status, 200) << "call " << i << ": " << geometry.body.substr(0, 300);
    const HttpReply planned = HttpPost(port, "/api/strata.v1.PlannerService/Plan", ToJson(plan));
    ASSERT_EQ(planned.status, 200) << "call " << i << ": " << planned.body.substr(0, 300);
  }
  fs::remove_all(store);
}

// A connection from 127.0.0.2 (another client as far as the server can tell), left silent.
int SilentConnection(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  from.sin_addr.s_addr = htonl(0x7f000002);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0 ||
      connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// 200 silent connections kept the page from everyone for about 250 s: each held one of
// civetweb's 8 threads for its 10 s read timeout. Now a connection costs no thread, one client
// holds at most kHttpMaxConnectionsPerClient of them (the rest are closed at once), and a
// silent one is closed after kHttpIdleTimeoutS.
TEST_F(ServerHttpTest, SilentConnectionsFromOneClientDoNotKeepThePageFromOthers) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--http-port", "0"}));
  const int port = server_->http_port();
  constexpr int kSilent = 200;
  std::vector<int> silent;
  for (int i = 0; i < kSilent; ++i) {
    const int fd = SilentConnection(port);
    ASSERT_GE(fd, 0) << "connection " << i;
    silent.push_back(fd);
  }
  // Another client is served at once (Exchange gives up after 30 s of silence).
  EXPECT_THAT(HttpGet(port, "/"), HasSubstr("<title>Strata viewer</title>"));
  EXPECT_EQ(HttpPost(port, "/api/strata.v1.MapService/ListMaps", "{}").status, 200);
  // The silent client's connections beyond its share were closed by the server.
  int closed = 0;
  EXPECT_TRUE(Eventually(
      [&] {
        for (int& fd : silent) {
          if (fd < 0) continue;
          pollfd ready{fd, POLLIN, 0};
          char byte;
          if (poll(&ready, 1, 0) == 1 && recv(fd, &byte, 1, MSG_DONTWAIT) == 0) {
            close(fd);
            fd = -1;
            ++closed;
          }
        }
        return closed >= kSilent - static_cast<int>(kHttpMaxConnectionsPerClient);
      },
      std::chrono::seconds(30)))
      << closed << " of " << kSilent << " closed";
  for (const int fd : silent) {
    if (fd >= 0) close(fd);
  }
}

// A body shorter than its Content-Length was answered after a 10 s wait as if it were whole.
// Now a request that does not arrive whole is never answered: the client that stopped sending
// gets its connection closed.
TEST_F(ServerHttpTest, ABodyShorterThanItsLengthIsNeverProcessed) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--http-port", "0"}));
  const int port = server_->http_port();
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to), 0);
  const std::string request =
      "POST /api/strata.v1.MapService/ListMaps HTTP/1.1\r\nHost: 127.0.0.1\r\n"
      "Content-Length: 100\r\n\r\n{}";
  ASSERT_EQ(send(fd, request.data(), request.size(), MSG_NOSIGNAL),
            static_cast<ssize_t>(request.size()));
  shutdown(fd, SHUT_WR);  // Nothing more comes.
  const timeval patience{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &patience, sizeof patience);
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = recv(fd, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, n);
  close(fd);
  EXPECT_THAT(answer, Not(HasSubstr("200 OK"))) << answer;
  EXPECT_THAT(answer, Not(HasSubstr("\"maps\""))) << answer;
}

// A body without a Content-Length (chunked) is counted as it comes: past the limit it is
// answered 413 too, and nothing past the limit is kept.
TEST_F(ServerHttpTest, AChunkedBodyPastTheLimitIsRefused) {
  ASSERT_NO_FATAL_FAILURE(
      StartServer({"--http-port", "0", "--max-receive-message-bytes", "1114112"}));
  const std::string chunk(64 * 1024, ' ');
  std::string request =
      "POST /api/strata.v1.MapService/ListMaps HTTP/1.1\r\nHost: 127.0.0.1\r\n"
      "Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n";
  char size[16];
  std::snprintf(size, sizeof size, "%zx\r\n", chunk.size());
  for (int i = 0; i < 20; ++i) request += size + chunk + "\r\n";  // 1.25 MiB of spaces.
  request += "0\r\n\r\n";
  const HttpReply reply = HttpExchange(server_->http_port(), request);
  EXPECT_EQ(reply.status, 413) << reply.body.substr(0, 300);
  EXPECT_THAT(reply.body, HasSubstr("--max-receive-message-bytes"));
}

TEST_F(ServerHttpTest, StopsWithTheServer) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--http-port", "0"}));
  ASSERT_EQ(HttpPost(server_->http_port(), "/api/strata.v1.MapService/ListMaps", "").status, 200);
  server_->Signal(SIGTERM);
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(30)), 0) << server_->Log();
}

TEST_F(ServerHttpTest, WithTlsTheViewerIsServedOnLoopbackOnly) {
  const fs::path dir = fs::temp_directory_path() / ("strata_http_tls_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path cert = dir / "cert.pem", key = dir / "key.pem";
  const std::string command =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -addext "
      "subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
      key.string() + " -out " + cert.string() + " >/dev/null 2>&1";
  if (std::system(command.c_str()) != 0) GTEST_SKIP() << "openssl could not make a certificate";
  const std::vector<std::string> tls = {"--tls-cert", cert.string(), "--tls-key", key.string()};
  // On every address (the default): refused at start, saying why and what to do.
  const auto refused = test_util::RunCommand({STRATA_SERVER_BINARY, "--listen", "127.0.0.1:0",
                                              "--metrics-port", "-1", "--no-preload", tls[0],
                                              tls[1], tls[2], tls[3], "--http-port", "0"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("--http-address 127.0.0.1"));
  // On loopback: served, plain.
  std::vector<std::string> args = tls;
  args.insert(args.end(), {"--http-port", "0", "--http-address", "127.0.0.1"});
  server_ = ServerProcess::Start(args);
  ASSERT_NE(server_, nullptr);
  EXPECT_THAT(HttpGet(server_->http_port(), "/"), HasSubstr("<title>Strata viewer</title>"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace strata::server::testing
