#pragma once
// A fixture that starts a real strata-server per test (on an ephemeral port) and gives
// stubs to it; on failure it prints the server's log.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server_process.hpp"
#include "server_test_util.hpp"

namespace strata::server::testing {

class ServerFixture : public ::testing::Test {
 protected:
  /// Starts the server with the shared maps as map root, plus `extra` flags, and waits
  /// until it is SERVING (every preloaded map ACTIVE).
  void StartServer(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--map-root", STRATA_SHARED_MAPS_DIR};
    args.insert(args.end(), extra.begin(), extra.end());
    server_ = ServerProcess::Start(args);
    ASSERT_NE(server_, nullptr);
    ASSERT_TRUE(server_->WaitServing(std::chrono::seconds(60))) << server_->Log();
    channel_ = server_->NewChannel();
    maps_ = v1::MapService::NewStub(channel_);
    planner_ = v1::PlannerService::NewStub(channel_);
  }

  void TearDown() override {
    if (HasFailure() && server_ != nullptr) {
      std::fprintf(stderr, "--- strata-server log ---\n%s\n", server_->Log().c_str());
    }
  }

  static bool HaveSpiral() {
    return std::filesystem::exists(std::string(STRATA_SHARED_MAPS_DIR) + "/spiral0.3_2.pcd");
  }

  /// CreateMap with wait; fails the test unless the map becomes ACTIVE.
  v1::Map CreateAndWait(v1::CreateMapRequest request, double deadline_s = 120) {
    request.set_wait(true);
    grpc::ClientContext context;
    SetDeadline(&context, deadline_s);
    v1::Map map;
    const grpc::Status status = maps_->CreateMap(&context, request, &map);
    EXPECT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE);
    return map;
  }

  v1::Map CreateSpiral(const std::string& id = "spiral", double resolution_m = 0.3) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_file()->set_path("spiral0.3_2.pcd");
    request.mutable_terrain()->set_resolution_m(resolution_m);
    return CreateAndWait(request);
  }

  grpc::Status Plan(const v1::PlanRequest& request, v1::PlanResponse* response,
                    double deadline_s = 60) {
    grpc::ClientContext context;
    SetDeadline(&context, deadline_s);
    return planner_->Plan(&context, request, response);
  }

  std::unique_ptr<ServerProcess> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MapService::Stub> maps_;
  std::unique_ptr<v1::PlannerService::Stub> planner_;
};

}  // namespace strata::server::testing
