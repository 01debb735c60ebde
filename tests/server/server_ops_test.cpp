// Operating the server: concurrent clients while maps come and go, draining on SIGTERM, and
// the Prometheus metrics.
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <future>
#include <regex>
#include <set>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <grpc/health/v1/health.grpc.pb.h>
#include <grpc/reflection/v1/reflection.grpc.pb.h>
#include <grpcpp/impl/codegen/client_unary_call.h>
#include <grpcpp/impl/codegen/rpc_method.h>

#include "server_fixture.hpp"
#include "test_util/run_command.hpp"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

class ServerOpsTest : public ServerFixture {};

// gRPC turns SO_REUSEPORT on unless told not to: a second server on a taken port used to log
// "listening" and take a random share of the first one's calls.
TEST_F(ServerOpsTest, ASecondServerOnATakenPortRefusesToStartUnlessBothShareIt) {
  server_ = ServerProcess::Start({"--no-preload"});
  ASSERT_NE(server_, nullptr);
  const std::vector<std::string> second = {"--listen", server_->address(), "--metrics-port", "-1",
                                           "--no-preload"};
  ASSERT_EQ(ServerProcess::Start(second), nullptr);
  std::vector<std::string> command = {STRATA_SERVER_BINARY};
  command.insert(command.end(), second.begin(), second.end());
  const test_util::CommandResult refused = test_util::RunCommand(command);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("address in use"));

  // Two that both ask to share the port both serve.
  const auto first_sharing = ServerProcess::Start({"--no-preload", "--reuse-port"});
  ASSERT_NE(first_sharing, nullptr);
  const auto second_sharing =
      ServerProcess::Start({"--listen", first_sharing->address(), "--metrics-port", "-1",
                            "--no-preload", "--reuse-port"});
  EXPECT_NE(second_sharing, nullptr);
}

// The metrics port, served by the server's own HTTP server, names its flags when it is taken.
TEST_F(ServerOpsTest, ATakenMetricsPortStopsTheStartNamingItsFlags) {
  server_ = ServerProcess::Start({"--no-preload"});
  ASSERT_NE(server_, nullptr);
  const test_util::CommandResult refused = test_util::RunCommand(
      {STRATA_SERVER_BINARY, "--listen", "127.0.0.1:0", "--metrics-address", "127.0.0.1",
       "--metrics-port", std::to_string(server_->metrics_port()), "--no-preload"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("--metrics-address, --metrics-port: cannot serve metrics on "
                                     "127.0.0.1:" +
                                     std::to_string(server_->metrics_port())));
}

TEST_F(ServerOpsTest, SixteenClientsPlanOnTwoMapsWhileAThirdComesAndGoes) {
  // This test is about every call being served while maps come and go, not about latency:
  // 16 plans share two planning slots, under a sanitiser, beside another test, and the first
  // plan on each map builds its graph. So each plan may take most of its call's 120 s.
  constexpr double kPlanBudgetS = 100;
  ASSERT_NO_FATAL_FAILURE(StartServer({"--preload", "demo=scene:two_level_ramp", "--preload",
                                       "room=scene:stairs_ramp_room", "--max-plan-time-s",
                                       std::to_string(kPlanBudgetS)}));
  constexpr int kClients = 16;
  constexpr int kPlansPerClient = 3;
  std::atomic<bool> planning{true};

  // The third map: created and deleted over and over while the clients plan.
  auto churn = std::async(std::launch::async, [&] {
    auto stub = v1::MapService::NewStub(server_->NewChannel());
    int cycles = 0;
    while (planning || cycles < 2) {
      grpc::ClientContext create_context;
      SetDeadline(&create_context, 60);
      v1::CreateMapRequest create;
      create.set_map_id("churn");
      create.mutable_scene()->set_name("uneven_terrain");
      create.mutable_scene()->set_seed(static_cast<std::uint32_t>(cycles));
      create.set_wait(cycles % 2 == 0);  // Delete some while still CREATING.
      v1::Map map;
      const grpc::Status created = stub->CreateMap(&create_context, create, &map);
      EXPECT_TRUE(created.ok()) << created.error_message();
      grpc::ClientContext delete_context;
      v1::DeleteMapRequest remove;
      remove.set_map_id("churn");
      v1::DeleteMapResponse removed;
      EXPECT_TRUE(stub->DeleteMap(&delete_context, remove, &removed).ok());
      ++cycles;
    }
    return cycles;
  });

  std::vector<std::future<int>> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.push_back(std::async(std::launch::async, [this, c] {
      auto stub = v1::PlannerService::NewStub(server_->NewChannel());
      int ok = 0;
      for (int i = 0; i < kPlansPerClient; ++i) {
        const bool on_demo = (c + i) % 2 == 0;
        // Demo: floor to deck. Room: across the floor, between the stairs and the walls.
        v1::PlanRequest request = on_demo
                                      ? PlanRequestFor("demo", 2, 2 + 0.1 * c, 0.3, 10, 10, 3.3)
                                      : PlanRequestFor("room", 1, 1 + 0.1 * c, 0.3, 6.5, 4.5, 0.3);
        request.mutable_options()->set_time_budget_s(kPlanBudgetS);
        grpc::ClientContext context;
        SetDeadline(&context, 120);
        v1::PlanResponse response;
        const grpc::Status status = stub->Plan(&context, request, &response);
        EXPECT_TRUE(status.ok()) << (on_demo ? "demo: " : "room: ") << status.error_message();
        ok += status.ok() ? 1 : 0;
      }
      return ok;
    }));
  }
  int succeeded = 0;
  for (auto& client : clients) succeeded += client.get();
  planning = false;
  EXPECT_GE(churn.get(), 2);
  EXPECT_EQ(succeeded, kClients * kPlansPerClient);
}

// A call that cannot finish before the test lets it: an upload whose stream the client keeps
// open. The server's handler has started (its started counter says so) and waits for the
// rest of the stream, so it is provably in flight when SIGTERM lands; the client sends the
// rest only once the server refuses new calls. The call must then end with the server's own
// answer (drained), not be cut off, and the server exit 0 once it has.
TEST_F(ServerOpsTest, SigtermDrainsACallThatIsProvablyInFlight) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  grpc::ClientContext context;
  SetDeadline(&context, 60);
  v1::Map map;
  auto writer = maps_->UploadMap(&context, &map);
  // Two chunks of 400 points, one before the signal and one after: a server that stopped
  // reading at the signal would see a stream 400 points short.
  ASSERT_TRUE(writer->Write(UploadHeader("late", 800)));
  std::vector<float> xyz;
  for (int i = 0; i < 400; ++i) xyz.insert(xyz.end(), {0.1f * (i % 20), 0.1f * (i / 20), 0.0f});
  v1::UploadMapRequest chunk;
  chunk.mutable_chunk()->set_points(
      std::string(reinterpret_cast<const char*>(xyz.data()), xyz.size() * sizeof(float)));
  ASSERT_TRUE(writer->Write(chunk));

  const std::vector<std::string> upload = {"grpc_method=\"UploadMap\""};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  double started = 0;
  while (started < 1 && std::chrono::steady_clock::now() < deadline) {
    started = MetricValue(HttpGet(server_->metrics_port(), "/metrics"), "grpc_server_started_total",
                          upload);
  }
  ASSERT_EQ(started, 1) << "the upload's handler never started";
  server_->Signal(SIGTERM);
  // The server stops its map registry, then refuses new calls: once a new call is refused,
  // the registry has stopped, and the upload still in flight can only end one way.
  bool refusing = false;
  while (!refusing && std::chrono::steady_clock::now() < deadline) {
    grpc::ClientContext list_context;
    SetDeadline(&list_context, 5);
    v1::ListMapsResponse maps;
    refusing = !maps_->ListMaps(&list_context, v1::ListMapsRequest{}, &maps).ok();
  }
  ASSERT_TRUE(refusing) << "the server kept taking new calls after SIGTERM";

  // The rest of the stream, after the signal: the handler reads it all and refuses the new
  // map, as a server shutting down does. A call cut at the signal would end otherwise:
  // CANCELLED or UNAVAILABLE without the server's reason, or INVALID_ARGUMENT for a stream
  // 400 points short.
  ASSERT_TRUE(writer->Write(chunk));
  ASSERT_TRUE(writer->WritesDone());
  const CallError error = ErrorOf(writer->Finish());
  EXPECT_EQ(error.code, grpc::StatusCode::UNAVAILABLE) << error.message;
  EXPECT_EQ(error.reason, "SHUTTING_DOWN") << error.message;
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(30)), 0);
  const std::string log = server_->Log();
  EXPECT_THAT(log, HasSubstr("event=stopped"));
  EXPECT_THAT(log, HasSubstr("rpc=UploadMap map=late"));  // The handler ran to its end.
}

// On SIGTERM the port stayed open for no time at all, so load balancers kept sending calls to
// a server that refused them. With --drain-delay-s, health turns NOT_SERVING first and new
// calls are still answered while the delay runs.
TEST_F(ServerOpsTest, SigtermTurnsHealthNotServingWhileNewCallsAreStillServed) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--drain-delay-s", "60"}));
  auto health = grpc::health::v1::Health::NewStub(channel_);
  const auto status = [&] {
    grpc::ClientContext context;
    SetDeadline(&context, 5);
    grpc::health::v1::HealthCheckRequest request;
    grpc::health::v1::HealthCheckResponse response;
    health->Check(&context, request, &response);
    return response.status();
  };
  ASSERT_EQ(status(), grpc::health::v1::HealthCheckResponse::SERVING);
  server_->Signal(SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (status() != grpc::health::v1::HealthCheckResponse::NOT_SERVING &&
         std::chrono::steady_clock::now() < deadline) {
  }
  ASSERT_EQ(status(), grpc::health::v1::HealthCheckResponse::NOT_SERVING);
  v1::PlanResponse response;
  const grpc::Status plan = Plan(PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3), &response);
  EXPECT_TRUE(plan.ok()) << plan.error_message();
}

// A plan still running when the grace ends stops and tells its client why: UNAVAILABLE with
// reason SHUTTING_DOWN (it was cut without any reason before).
TEST_F(ServerOpsTest, APlanRunningPastTheGraceAnswersShuttingDown) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--shutdown-grace-s", "0", "--no-preload"}));
  v1::CreateMapRequest create;
  create.set_map_id("site");
  create.mutable_scene()->set_name("outdoor_site");
  create.mutable_scene()->set_size_m(120);
  CreateAndWait(create);
  // A profile of its own: the plan first builds its graph (a tenth of a second in a Release
  // build, several times that under the sanitisers), long enough to be caught in flight.
  v1::PlanRequest request = PlanRequestFor("site", 10, 10, 5, 110, 110, 5);
  request.clear_profile_name();
  request.mutable_profile()->set_max_step_m(0.123);
  v1::PlanResponse response;
  grpc::Status status;
  std::thread plan([&] { status = Plan(request, &response, 60); });
  const std::vector<std::string> plans = {"grpc_method=\"Plan\""};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  double started = 0;
  while (started < 1 && std::chrono::steady_clock::now() < deadline) {
    started = MetricValue(HttpGet(server_->metrics_port(), "/metrics"), "grpc_server_started_total",
                          plans);
  }
  server_->Signal(SIGTERM);
  plan.join();
  ASSERT_EQ(started, 1) << "the plan never started";
  const CallError error = ErrorOf(status);
  EXPECT_EQ(error.code, grpc::StatusCode::UNAVAILABLE) << error.message;
  EXPECT_EQ(error.reason, "SHUTTING_DOWN") << error.message;
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(30)), 0);
}

// A person's Ctrl-C does not wait for load balancers: SIGINT skips the drain delay.
TEST_F(ServerOpsTest, SigintSkipsTheDrainDelay) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--drain-delay-s", "600"}));
  server_->Signal(SIGINT);
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(60)), 0);
}

TEST_F(ServerOpsTest, MetricsShowTheCountersMoving) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  const std::string before = HttpGet(server_->metrics_port(), "/metrics");
  ASSERT_THAT(before, HasSubstr("grpc_server_started_total"));
  EXPECT_THAT(before, Not(HasSubstr("exposer_")));  // Only the families metrics.hpp lists.
  EXPECT_EQ(MetricValue(before, "strata_maps", {"state=\"active\""}), 1);
  EXPECT_GT(MetricValue(before, "strata_map_memory_bytes", {}), 0);
  EXPECT_EQ(MetricValue(before, "strata_map_assessment_seconds_count", {"stage=\"total\""}), 1);
  EXPECT_EQ(MetricValue(before, "strata_reservations", {}), 0);

  v1::PlanRequest reserved = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  reserved.mutable_fleet()->set_robot_id("m1");
  reserved.mutable_fleet()->set_reserve(true);
  v1::PlanResponse response;
  ASSERT_TRUE(Plan(reserved, &response).ok());
  ASSERT_FALSE(Plan(PlanRequestFor("nowhere", 2, 2, 0.3, 10, 10, 3.3), &response).ok());

  const std::string after = HttpGet(server_->metrics_port(), "/metrics");
  const std::vector<std::string> plan = {
      "grpc_method=\"Plan\"", "grpc_service=\"strata.v1.PlannerService\"", "grpc_type=\"unary\""};
  EXPECT_EQ(MetricValue(after, "grpc_server_started_total", plan) -
                MetricValue(before, "grpc_server_started_total", plan),
            2);
  std::vector<std::string> ok = plan, not_found = plan;
  ok.push_back("grpc_code=\"OK\"");
  not_found.push_back("grpc_code=\"NotFound\"");
  EXPECT_EQ(MetricValue(after, "grpc_server_handled_total", ok), 1);
  EXPECT_EQ(MetricValue(after, "grpc_server_handled_total", not_found), 1);
  EXPECT_EQ(MetricValue(after, "grpc_server_handling_seconds_count", plan), 2);
  EXPECT_EQ(MetricValue(after, "grpc_server_msg_received_total", plan), 2);
  EXPECT_EQ(MetricValue(after, "strata_plans_total", {"result=\"OK\""}), 1);
  EXPECT_EQ(MetricValue(after, "strata_reservations", {}), 1);
  EXPECT_EQ(MetricValue(after, "strata_reservations_expired_total", {}), 0);
  EXPECT_EQ(MetricValue(after, "strata_plans_total", {"result=\"MAP_NOT_FOUND\""}), 1);
  EXPECT_EQ(MetricValue(after, "strata_plan_duration_seconds_count", {"stage=\"search\""}), 1);
  // Health checks (the harness waits for SERVING with Watch) are counted like any other
  // service. Every served method has its series from the start, so name the method.
  EXPECT_GT(MetricValue(after, "grpc_server_started_total",
                        {"grpc_service=\"grpc.health.v1.Health\"", "grpc_method=\"Watch\""}),
            0);
}

// A client may call any path; every made-up one is counted under "unknown", so a thousand of
// them add no series to the exposition (they once grew it by 18 KB each).
// grpcurl and buf curl ask reflection v1 first (gRPC 1.51 serves only v1alpha): it lists the
// services and resolves the types a failed call's details carry (google.rpc.ErrorInfo).
TEST_F(ServerOpsTest, ReflectionV1ListsTheServicesAndResolvesErrorDetails) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  auto reflection = grpc::reflection::v1::ServerReflection::NewStub(channel_);
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  auto stream = reflection->ServerReflectionInfo(&context);
  grpc::reflection::v1::ServerReflectionRequest request;
  grpc::reflection::v1::ServerReflectionResponse response;

  request.set_list_services("");
  ASSERT_TRUE(stream->Write(request) && stream->Read(&response));
  std::vector<std::string> services;
  for (const auto& service : response.list_services_response().service()) {
    services.push_back(service.name());
  }
  EXPECT_THAT(services, ::testing::IsSupersetOf({"strata.v1.PlannerService", "strata.v1.MapService",
                                                 "grpc.reflection.v1.ServerReflection"}));

  request.set_file_containing_symbol("google.rpc.ErrorInfo");
  ASSERT_TRUE(stream->Write(request) && stream->Read(&response));
  ASSERT_TRUE(response.has_file_descriptor_response()) << response.DebugString();
  google::protobuf::FileDescriptorProto last;
  const auto& files = response.file_descriptor_response().file_descriptor_proto();
  ASSERT_TRUE(last.ParseFromString(files[files.size() - 1]));
  EXPECT_EQ(last.name(), "google/rpc/error_details.proto");

  request.set_file_containing_symbol("strata.v1.PlannerService.Plan");
  ASSERT_TRUE(stream->Write(request) && stream->Read(&response));
  EXPECT_GE(response.file_descriptor_response().file_descriptor_proto_size(), 2);

  request.set_file_containing_symbol("no.such.Thing");
  ASSERT_TRUE(stream->Write(request) && stream->Read(&response));
  EXPECT_EQ(response.error_response().error_code(), grpc::StatusCode::NOT_FOUND);
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
}

/// The values of every grpc_method label in a metrics page.
std::set<std::string> MethodLabels(const std::string& page) {
  static const std::regex kMethod("grpc_method=\"([^\"]*)\"");
  std::set<std::string> methods;
  for (std::sregex_iterator it(page.begin(), page.end(), kMethod), end; it != end; ++it) {
    methods.insert((*it)[1]);
  }
  return methods;
}

TEST_F(ServerOpsTest, CallsToUnknownMethodsShareOneSeries) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  const auto call = [&](const std::string& path) {
    const grpc::internal::RpcMethod method(path.c_str(), grpc::internal::RpcMethod::NORMAL_RPC);
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    v1::PlanRequest request;
    v1::PlanResponse response;
    return grpc::internal::BlockingUnaryCall(channel_.get(), method, &context, request, &response);
  };
  ASSERT_EQ(call("/strata.v1.NoSuchService/Nope0").error_code(), grpc::StatusCode::UNIMPLEMENTED);
  // The server counts a call as handled after its client has the answer: scrape once it has,
  // so that the first call's series are all there before the others come.
  const std::vector<std::string> unknown = {"grpc_service=\"unknown\"", "grpc_method=\"unknown\""};
  // If it never is, the line counts below say so.
  std::string before;
  (void)Eventually(
      [&] {
        before = HttpGet(server_->metrics_port(), "/metrics");
        return MetricValue(before, "grpc_server_handled_total", unknown) >= 1;
      },
      std::chrono::seconds(30));
  for (int i = 1; i < 200; ++i) call("/x" + std::to_string(i) + "/made-up-" + std::to_string(i));
  const std::string after = HttpGet(server_->metrics_port(), "/metrics");
  EXPECT_THAT(after, Not(HasSubstr("made-up")));
  EXPECT_THAT(after, Not(HasSubstr("NoSuchService")));
  EXPECT_EQ(MetricValue(after, "grpc_server_started_total", unknown), 200);
  // No method label was added: the 199 names share the first call's series. (Counting lines
  // instead flaked: a series of the first call, such as a message count, may appear after
  // its handled count does.)
  EXPECT_EQ(MethodLabels(after), MethodLabels(before));
}

}  // namespace
}  // namespace strata::server::testing
