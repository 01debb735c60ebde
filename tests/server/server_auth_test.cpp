// Access to a real strata-server: bearer tokens with roles (--auth-tokens) and TLS
// (--tls-cert, --tls-key). Anyone who reached the port could create, upload and delete any
// map, the demo included.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <grpc/health/v1/health.grpc.pb.h>

#include "server_fixture.hpp"

namespace strata::server::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kPlannerToken = "planner-token-for-tests-01";
const std::string kAdminToken = "admin-token-for-tests-0123";

class ServerAuthTest : public ServerFixture {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("strata_auth_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    ServerFixture::TearDown();
    fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(ServerAuthTest, TokensDecideWhoPlansAndWhoChangesMaps) {
  const fs::path tokens = dir_ / "tokens";
  std::ofstream(tokens) << kPlannerToken << " planner\n" << kAdminToken << " admin\n";
  ASSERT_NO_FATAL_FAILURE(StartServer({"--auth-tokens", tokens.string()}));  // Health is open.

  const auto plan = [&](const std::string& token) {
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    v1::PlanResponse response;
    return planner_->Plan(&context, PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3), &response);
  };
  const auto create = [&](const std::string& token) {
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    v1::CreateMapRequest request;
    request.set_map_id("hills");
    request.mutable_scene()->set_name("uneven_terrain");
    v1::Map map;
    return maps_->CreateMap(&context, request, &map);
  };

  CallError error = ErrorOf(plan(""));
  EXPECT_EQ(error.code, grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(error.reason, "UNAUTHENTICATED");
  EXPECT_THAT(error.message, HasSubstr("authorization: Bearer TOKEN"));
  EXPECT_EQ(ErrorOf(plan("not-a-token-of-this-server")).code, grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(plan(kPlannerToken).ok());
  EXPECT_TRUE(plan(kAdminToken).ok());

  error = ErrorOf(create(kPlannerToken));
  EXPECT_EQ(error.code, grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(error.reason, "PERMISSION_DENIED");
  EXPECT_EQ(ErrorOf(create("")).code, grpc::StatusCode::UNAUTHENTICATED);
  const grpc::Status admin = create(kAdminToken);
  EXPECT_TRUE(admin.ok()) << admin.error_message();
  // The dispatcher's calls are planning: a planner may make them, an unknown caller not.
  const auto estimate = [&](const std::string& token) {
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    v1::EstimateCostsRequest request;
    request.set_map_id("demo");
    request.set_profile_name("differential");
    SetXyz(request.add_starts_m(), 2, 2, 0.3);
    SetXyz(request.add_goals_m(), 10, 10, 3.3);
    v1::EstimateCostsResponse response;
    return planner_->EstimateCosts(&context, request, &response);
  };
  const auto batch = [&](const std::string& token) {
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    v1::PlanBatchRequest request;
    *request.add_requests() = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
    auto reader = planner_->PlanBatch(&context, request);
    v1::PlanBatchResponse item;
    int results = 0;
    while (reader->Read(&item)) results += item.has_response();
    const grpc::Status status = reader->Finish();
    return status.ok() && results != 1 ? grpc::Status(grpc::StatusCode::INTERNAL, "no plan")
                                       : status;
  };
  EXPECT_TRUE(estimate(kPlannerToken).ok());
  EXPECT_TRUE(batch(kPlannerToken).ok());
  EXPECT_EQ(ErrorOf(estimate("")).reason, "UNAUTHENTICATED");
  EXPECT_EQ(ErrorOf(batch("not-a-token-of-this-server")).reason, "UNAUTHENTICATED");

  // Tokens never reach the log.
  EXPECT_THAT(server_->Log(), Not(HasSubstr(kPlannerToken)));
  EXPECT_THAT(server_->Log(), Not(HasSubstr(kAdminToken)));
}

TEST_F(ServerAuthTest, TlsServesAClientThatTrustsItsCertificateAndNoPlaintextOne) {
  const fs::path cert = dir_ / "cert.pem", key = dir_ / "key.pem";
  const std::string command =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -addext "
      "subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
      key.string() + " -out " + cert.string() + " >/dev/null 2>&1";
  if (std::system(command.c_str()) != 0) GTEST_SKIP() << "openssl could not make a certificate";
  server_ = ServerProcess::Start(
      {"--map-root", TestMapRoot(), "--tls-cert", cert.string(), "--tls-key", key.string()});
  ASSERT_NE(server_, nullptr);
  std::ifstream in(cert);
  grpc::SslCredentialsOptions tls;
  tls.pem_root_certs.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  const auto channel = grpc::CreateChannel(server_->address(), grpc::SslCredentials(tls));

  auto health = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext watch_context;
  SetDeadline(&watch_context, 60);
  auto watch = health->Watch(&watch_context, grpc::health::v1::HealthCheckRequest());
  grpc::health::v1::HealthCheckResponse status;
  while (watch->Read(&status) &&
         status.status() != grpc::health::v1::HealthCheckResponse::SERVING) {
  }
  ASSERT_EQ(status.status(), grpc::health::v1::HealthCheckResponse::SERVING) << server_->Log();
  watch_context.TryCancel();
  watch->Finish();

  auto planner = v1::PlannerService::NewStub(channel);
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::PlanResponse response;
  const grpc::Status over_tls =
      planner->Plan(&context, PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3), &response);
  EXPECT_TRUE(over_tls.ok()) << over_tls.error_message();

  auto plaintext = v1::PlannerService::NewStub(server_->NewChannel());
  grpc::ClientContext plain_context;
  SetDeadline(&plain_context, 10);
  EXPECT_FALSE(
      plaintext->Plan(&plain_context, PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3), &response)
          .ok());
}

}  // namespace
}  // namespace strata::server::testing
