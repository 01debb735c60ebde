// The server's memory budget end to end (--max-memory, --max-graph-memory) against the real
// strata-server: uploads in progress are counted and refused past it with the figures, and
// robot profiles made up by clients cannot grow a map's graphs past their bound. And the
// server's malloc asks for huge pages for its large blocks (common/free_memory.hpp).
#include <chrono>
#include <fstream>
#include <iterator>
#include <string>

#include <gmock/gmock.h>

#include "server_fixture.hpp"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;

constexpr std::uint64_t kMiB = 1 << 20;

class MemoryBudgetServerTest : public ServerFixture {
 protected:
  double Reserved(const std::string& use) const {
    return MetricValue(HttpGet(server_->metrics_port(), "/metrics"), "strata_memory_reserved_bytes",
                       {"use=\"" + use + "\""});
  }
};

// An upload held open after its header, as a slow or hostile client would.
struct OpenUpload {
  grpc::ClientContext context;
  v1::Map map;
  std::unique_ptr<grpc::ClientWriter<v1::UploadMapRequest>> writer;
};

TEST_F(MemoryBudgetServerTest, UploadsInProgressCountAndThoseBeyondTheBudgetAreRefused) {
  // 300 MiB in all, of which making the demo needed 100 (released once it was made).
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-memory", std::to_string(300 * kMiB),
                                       "--max-assessment-memory", std::to_string(100 * kMiB)}));
  // Ten million points announced: 114 MiB each, counted at the header.
  constexpr std::uint64_t kPoints = 10'000'000;
  const double each = static_cast<double>(kPoints * 12);
  std::vector<std::unique_ptr<OpenUpload>> open;
  for (int i = 0; i < 2; ++i) {
    auto upload = std::make_unique<OpenUpload>();
    upload->writer = maps_->UploadMap(&upload->context, &upload->map);
    ASSERT_TRUE(upload->writer->Write(UploadHeader("held" + std::to_string(i), kPoints)));
    open.push_back(std::move(upload));
  }
  ASSERT_TRUE(Eventually([&] { return Reserved("uploads") == 2 * each; }, std::chrono::seconds(10)))
      << Reserved("uploads");

  // A third does not fit beside them: refused at its header, with the figures.
  {
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    v1::Map map;
    auto writer = maps_->UploadMap(&context, &map);
    writer->Write(UploadHeader("third", kPoints));
    writer->WritesDone();
    const CallError error = ErrorOf(writer->Finish());
    EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED) << error.message;
    EXPECT_THAT(error.message, HasSubstr("uploading map 'third' needs 114.4 MiB"));
    EXPECT_THAT(error.message, HasSubstr("--max-memory 300.0 MiB"));
    EXPECT_THAT(error.fields, ::testing::ElementsAre("header.point_count"));
  }
  // The clients give up: their memory goes back, and the third fits.
  for (auto& upload : open) upload->context.TryCancel();
  for (auto& upload : open) upload->writer->Finish();
  ASSERT_TRUE(Eventually([&] { return Reserved("uploads") == 0; }, std::chrono::seconds(10)));
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::Map map;
  auto writer = maps_->UploadMap(&context, &map);
  ASSERT_TRUE(writer->Write(UploadHeader("third", kPoints)));
  EXPECT_TRUE(Eventually([&] { return Reserved("uploads") == each; }, std::chrono::seconds(10)));
  context.TryCancel();
  writer->Finish();
}

TEST_F(MemoryBudgetServerTest, AMapThatCannotBeMadeNowIsRefusedAtOnce) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-memory", std::to_string(300 * kMiB),
                                       "--max-assessment-memory", std::to_string(100 * kMiB)}));
  // An upload holds 229 MiB: too little is left to make a map beside it.
  OpenUpload upload;
  upload.writer = maps_->UploadMap(&upload.context, &upload.map);
  ASSERT_TRUE(upload.writer->Write(UploadHeader("held", 20'000'000)));
  ASSERT_TRUE(Eventually([&] { return Reserved("uploads") > 0; }, std::chrono::seconds(10)));
  v1::CreateMapRequest request;
  request.set_map_id("later");
  request.mutable_scene()->set_name("two_level_ramp");
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::Map map;
  const CallError error = ErrorOf(maps_->CreateMap(&context, request, &map));
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED) << error.message;
  EXPECT_THAT(error.message,
              HasSubstr("making map 'later' (--max-assessment-memory) needs 100.0 MiB"));
  upload.context.TryCancel();
  upload.writer->Finish();
}

// Started without the tunable (as the fixture starts it), the server runs with it: a map
// version's arrays made on a call's thread fault in 2 MB at a time (1.1-1.3 s for a 400 m
// site's scan without).
TEST_F(MemoryBudgetServerTest, TheServerRunsWithHugePagesForLargeBlocks) {
  ASSERT_EQ(std::getenv("GLIBC_TUNABLES"), nullptr) << "the test must start it without";
  ASSERT_NO_FATAL_FAILURE(StartServer({"--no-preload"}));
  std::ifstream environ("/proc/" + std::to_string(server_->pid()) + "/environ");
  const std::string variables((std::istreambuf_iterator<char>(environ)),
                              std::istreambuf_iterator<char>());
  EXPECT_THAT(variables, HasSubstr("GLIBC_TUNABLES=glibc.malloc.hugetlb=1"));
}

TEST_F(MemoryBudgetServerTest, ABudgetTooSmallToMakeAnyMapIsSaidAtStart) {
  // A replica that only serves maps from a store may run so; it says so, and refuses to make
  // maps.
  ASSERT_NO_FATAL_FAILURE(StartServer({"--no-preload", "--max-memory", std::to_string(300 * kMiB),
                                       "--max-assessment-memory", std::to_string(400 * kMiB)}));
  EXPECT_TRUE(
      server_->WaitForLog("--max-assessment-memory 400.0 MiB is more than the whole "
                          "memory budget (--max-memory 300.0 MiB)",
                          std::chrono::seconds(10)));
  v1::CreateMapRequest request;
  request.set_map_id("never");
  request.mutable_scene()->set_name("two_level_ramp");
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::Map map;
  const CallError error = ErrorOf(maps_->CreateMap(&context, request, &map));
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED) << error.message;
  EXPECT_THAT(error.message, HasSubstr("needs 400.0 MiB"));
}

TEST_F(MemoryBudgetServerTest, ProfilesMadeUpByClientsKeepAMapsGraphsWithinTheirBound) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-graph-memory", std::to_string(1 * kMiB)}));
  const auto demo_bytes = [&] {
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    v1::GetMapRequest request;
    request.set_map_id("demo");
    v1::Map map;
    EXPECT_TRUE(maps_->GetMap(&context, request, &map).ok());
    return map.memory_bytes();
  };
  const std::uint64_t model_bytes = demo_bytes();  // No plan yet: no graph.
  std::uint64_t most = 0;
  for (int i = 0; i < 12; ++i) {
    v1::PlanRequest request = PlanRequestFor("demo", 1.0, 1.0, 0.0, 14.0, 8.0, 0.0);
    request.clear_profile_name();
    request.mutable_profile()->set_max_step_m(0.10 + 0.001 * i);  // A graph of its own each.
    v1::PlanResponse response;
    const grpc::Status status = Plan(request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    most = std::max(most, demo_bytes());
  }
  EXPECT_GT(most, model_bytes);  // Graphs were built...
  // ...and at most the bound's worth of them (plus the newest, always kept) stayed.
  EXPECT_LE(most, model_bytes + 2 * kMiB) << "model " << model_bytes;
}

}  // namespace
}  // namespace strata::server::testing
