// Access to a real strata-server: bearer tokens with roles (--auth-tokens) and TLS
// (--tls-cert, --tls-key). Anyone who reached the port could create, upload and delete any
// map, the demo included.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include <gmock/gmock.h>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/empty.pb.h>
#include <grpc/health/v1/health.grpc.pb.h>
#include <grpcpp/impl/codegen/client_unary_call.h>
#include <grpcpp/impl/codegen/rpc_method.h>

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

// Every method of both services, from every kind of caller, over gRPC and through the web
// viewer's API: the role table decides, in one place for both. The policy is written here on
// its own: the four calls that change maps need an admin, every other one a planner.
TEST_F(ServerAuthTest, EveryMethodAnswersEachCallerAsTheRoleTableSays) {
  const fs::path tokens = dir_ / "tokens";
  std::ofstream(tokens) << kPlannerToken << " planner\n" << kAdminToken << " admin\n";
  ASSERT_NO_FATAL_FAILURE(StartServer({"--auth-tokens", tokens.string(), "--http-port", "0"}));
  const std::set<std::string> kChangesMaps = {"CreateMap", "UploadMap", "UpdateMap", "DeleteMap"};
  const std::set<std::string> kServedOverHttp = {"ListMaps", "GetMap", "GetMapGeometry", "Plan",
                                                 "ListRecentPlans"};
  const std::string kUnknownToken = "not-a-token-of-this-server";
  const auto auth_error = [](grpc::StatusCode code) {
    return code == grpc::StatusCode::UNAUTHENTICATED || code == grpc::StatusCode::PERMISSION_DENIED;
  };
  int methods = 0;
  const auto* pool = google::protobuf::DescriptorPool::generated_pool();
  for (const google::protobuf::ServiceDescriptor* service :
       {pool->FindServiceByName("strata.v1.MapService"),
        pool->FindServiceByName("strata.v1.PlannerService")}) {
    ASSERT_NE(service, nullptr);
    for (int i = 0; i < service->method_count(); ++i) {
      ++methods;
      const std::string name = service->method(i)->name();
      const std::string path = "/" + service->full_name() + "/" + name;
      const bool admin_only = kChangesMaps.count(name) != 0;
      for (const std::string& token : {std::string(), kUnknownToken, kPlannerToken, kAdminToken}) {
        SCOPED_TRACE(path + " with " + (token.empty() ? "no token" : token));
        // gRPC: an empty message is every request's default; the answer's kind is all we read.
        const grpc::internal::RpcMethod method(path.c_str(), grpc::internal::RpcMethod::NORMAL_RPC);
        grpc::ClientContext context;
        SetDeadline(&context, 30);
        if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
        google::protobuf::Empty request;
        google::protobuf::Empty response;
        const grpc::StatusCode code =
            grpc::internal::BlockingUnaryCall(channel_.get(), method, &context, request, &response)
                .error_code();
        // Through the viewer's API: the same, for what it serves.
        std::vector<std::string> headers;
        if (!token.empty()) headers.push_back("Authorization: Bearer " + token);
        const int http = HttpPost(server_->http_port(), "/api" + path, "{}", headers).status;
        if (token.empty() || token == kUnknownToken) {
          EXPECT_EQ(code, grpc::StatusCode::UNAUTHENTICATED);
        } else if (token == kPlannerToken && admin_only) {
          EXPECT_EQ(code, grpc::StatusCode::PERMISSION_DENIED);
        } else {
          EXPECT_FALSE(auth_error(code)) << code;
        }
        if (kServedOverHttp.count(name) == 0) {
          EXPECT_EQ(http, 404);
        } else if (token.empty() || token == kUnknownToken) {
          EXPECT_EQ(http, 401);
        } else {
          EXPECT_NE(http, 401);
          EXPECT_NE(http, 403);
        }
      }
    }
  }
  EXPECT_EQ(methods, 11);
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
