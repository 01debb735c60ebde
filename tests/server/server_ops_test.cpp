// Operating the server: concurrent clients while maps come and go, draining on SIGTERM, and
// the Prometheus metrics.
#include <signal.h>

#include <atomic>
#include <future>
#include <thread>

#include <gmock/gmock.h>
#include <grpc/health/v1/health.grpc.pb.h>

#include "server_fixture.hpp"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;

class ServerOpsTest : public ServerFixture {};

TEST_F(ServerOpsTest, SixteenClientsPlanOnTwoMapsWhileAThirdComesAndGoes) {
  ASSERT_NO_FATAL_FAILURE(StartServer(
      {"--preload", "demo=scene:two_level_ramp", "--preload", "room=scene:stairs_ramp_room"}));
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
        const v1::PlanRequest request =
            on_demo ? PlanRequestFor("demo", 2, 2 + 0.1 * c, 0.3, 10, 10, 3.3)
                    : PlanRequestFor("room", 1, 1 + 0.1 * c, 0.3, 6.5, 4.5, 0.3);
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

TEST_F(ServerOpsTest, SigtermDrainsInFlightCallsAndExitsZero) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-concurrent-plans", "1"}));
  constexpr int kCalls = 6;
  std::vector<std::future<grpc::Status>> calls;
  for (int i = 0; i < kCalls; ++i) {
    calls.push_back(std::async(std::launch::async, [this, i] {
      auto stub = v1::PlannerService::NewStub(server_->NewChannel());
      grpc::ClientContext context;
      SetDeadline(&context, 60);
      v1::PlanResponse response;
      return stub->Plan(&context, PlanRequestFor("demo", 2, 2 + 0.2 * i, 0.3, 10, 10, 3.3),
                        &response);
    }));
  }
  // Every call has reached the server (one plans, the rest queue for the single slot) once
  // the started counter says so; then the signal lands with all of them in flight.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  double started = 0;
  while (started < kCalls && std::chrono::steady_clock::now() < deadline) {
    started = MetricValue(HttpGet(server_->metrics_port(), "/metrics"), "grpc_server_started_total",
                          {"grpc_method=\"Plan\""});
  }
  ASSERT_EQ(started, kCalls);
  server_->Signal(SIGTERM);
  for (auto& call : calls) {
    const grpc::Status status = call.get();
    EXPECT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(30)), 0);
  const std::string log = server_->Log();
  EXPECT_THAT(log, HasSubstr("event=shutdown signal=SIGTERM"));
  EXPECT_THAT(log, HasSubstr("event=stopped"));
}

TEST_F(ServerOpsTest, MetricsShowTheCountersMoving) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  const std::string before = HttpGet(server_->metrics_port(), "/metrics");
  ASSERT_THAT(before, HasSubstr("grpc_server_started_total"));
  EXPECT_EQ(MetricValue(before, "strata_maps", {"state=\"active\""}), 1);
  EXPECT_GT(MetricValue(before, "strata_map_memory_bytes", {}), 0);
  EXPECT_EQ(MetricValue(before, "strata_map_assessment_seconds_count", {"stage=\"total\""}), 1);

  v1::PlanResponse response;
  ASSERT_TRUE(Plan(PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3), &response).ok());
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
  EXPECT_EQ(MetricValue(after, "strata_plans_total", {"result=\"MAP_NOT_FOUND\""}), 1);
  EXPECT_EQ(MetricValue(after, "strata_plan_duration_seconds_count", {"stage=\"search\""}), 1);
  // Health checks are counted like any other service.
  EXPECT_GT(
      MetricValue(after, "grpc_server_started_total", {"grpc_service=\"grpc.health.v1.Health\""}),
      0);
}

}  // namespace
}  // namespace strata::server::testing
