#pragma once
// A fixture that starts a real strata-server per test (on an ephemeral port) and gives
// stubs to it; on failure it prints the server's log.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server_process.hpp"
#include "server_test_util.hpp"

namespace strata::server::testing {

/// The map root the test servers use: the shared maps beside the repository, whose
/// README.md is a file under the root that is no point cloud; without them (a container
/// build), a temporary directory holding only such a README.md, so the tests that need no
/// shared map still run and the others skip.
inline const std::string& TestMapRoot() {
  static const std::string root = []() -> std::string {
    namespace fs = std::filesystem;
    if (fs::is_directory(STRATA_SHARED_MAPS_DIR)) return STRATA_SHARED_MAPS_DIR;
    const fs::path dir =
        fs::temp_directory_path() / ("strata-test-maps-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    if (std::FILE* text = std::fopen((dir / "README.md").c_str(), "w")) {
      std::fputs("No maps here: the shared maps were not found.\n", text);
      std::fclose(text);
    }
    return dir.string();
  }();
  return root;
}

class ServerFixture : public ::testing::Test {
 protected:
  /// Starts the server with TestMapRoot() as map root, plus `extra` flags, and waits until
  /// it is SERVING (every preloaded map ACTIVE).
  void StartServer(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--map-root", TestMapRoot()};
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

  static bool HaveSpiral() { return std::filesystem::exists(TestMapRoot() + "/spiral0.3_2.pcd"); }

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
