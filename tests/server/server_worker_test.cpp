// Maps are made in worker processes (server/maps/map_worker.hpp): against the real strata-server,
// a worker that crashes, runs past its memory or time, or whose map is deleted, fails or
// stops that one map at once while the server goes on serving every other map and client.
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <vector>

#include <gmock/gmock.h>

#include "server_fixture.hpp"
#include "test_util/time_scale.hpp"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

// The processes `parent` started and has not reaped yet.
std::vector<pid_t> ChildrenOf(pid_t parent) {
  std::vector<pid_t> children;
  std::error_code error;
  const std::filesystem::path tasks = "/proc/" + std::to_string(parent) + "/task";
  for (const auto& task : std::filesystem::directory_iterator(tasks, error)) {
    std::ifstream list(task.path() / "children");
    for (pid_t pid = 0; list >> pid;) children.push_back(pid);
  }
  return children;
}

bool Exists(pid_t pid) { return kill(pid, 0) == 0 || errno != ESRCH; }

class MapWorkerServerTest : public ServerFixture {
 protected:
  // A 200 m site keeps its worker assessing for seconds, long enough to be caught at it.
  grpc::Status CreateSite(const std::string& id, bool wait, v1::Map* map, double size_m = 200) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_scene()->set_name("outdoor_site");
    request.mutable_scene()->set_size_m(size_m);
    request.set_wait(wait);
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    return maps_->CreateMap(&context, request, map);
  }

  v1::Map Get(const std::string& id) {
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    v1::GetMapRequest request;
    request.set_map_id(id);
    v1::Map map;
    EXPECT_TRUE(maps_->GetMap(&context, request, &map).ok());
    return map;
  }

  // The worker making map `id`, once it is assessing (its points read).
  pid_t WorkerAssessing(const std::string& id) {
    pid_t worker = -1;
    const bool found = Eventually(
        [&] {
          if (Get(id).stage() != v1::MAP_CREATION_STAGE_ASSESSING) return false;
          const std::vector<pid_t> children = ChildrenOf(server_->pid());
          if (children.size() != 1) return false;
          worker = children.front();
          return true;
        },
        std::chrono::seconds(60));
    EXPECT_TRUE(found) << "map " << id << " never reached ASSESSING in a worker";
    return worker;
  }

  void ExpectDemoPlans() {
    v1::PlanResponse response;
    const grpc::Status status =
        Plan(PlanRequestFor("demo", 1.0, 1.0, 0.0, 14.0, 8.0, 0.0), &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
  }
};

TEST_F(MapWorkerServerTest, ACrashingWorkerFailsItsMapAndTheServerServesOn) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::Map map;
  ASSERT_TRUE(CreateSite("doomed", false, &map).ok());
  const pid_t worker = WorkerAssessing("doomed");
  ASSERT_GT(worker, 0);
  kill(worker, SIGSEGV);  // As a reader or an assessment would on a bug.
  ASSERT_TRUE(Eventually([&] { return Get("doomed").state() == v1::MAP_STATE_FAILED; },
                         std::chrono::seconds(10)));
  const v1::Map failed = Get("doomed");
  EXPECT_EQ(failed.failure().reason(), "MAP_LOAD_FAILED");
  EXPECT_THAT(failed.failure().message(), HasSubstr("crashed (SIGSEGV"));
  ExpectDemoPlans();
  // The id is free again and a new worker makes the map (a small site: waiting for a whole
  // 200 m one was most of this test's 43 s under ASan).
  ASSERT_TRUE(CreateSite("doomed", true, &map, 40).ok());
  EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE);
}

TEST_F(MapWorkerServerTest, DeletingACreatingMapStopsItsWorkerAtOnce) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::Map map;
  ASSERT_TRUE(CreateSite("big", false, &map).ok());
  const pid_t worker = WorkerAssessing("big");
  ASSERT_GT(worker, 0);
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::DeleteMapRequest request;
  request.set_map_id("big");
  v1::DeleteMapResponse response;
  // Frozen first: a worker that can neither finish nor notice anything is gone only if the
  // server kills it (the wait below only keeps a broken server from hanging the test).
  ASSERT_EQ(kill(worker, SIGSTOP), 0);
  const auto asked = Clock::now();
  ASSERT_TRUE(maps_->DeleteMap(&context, request, &response).ok());
  EXPECT_TRUE(Eventually([&] { return !Exists(worker); }, std::chrono::seconds(60)))
      << "the frozen worker outlived its deleted map: it was not killed";
  const double stopped_s = std::chrono::duration<double>(Clock::now() - asked).count();
  std::printf("worker gone %.3f s after DeleteMap\n", stopped_s);
  // The single assessment slot is free: the next map is made at once.
  v1::CreateMapRequest next;
  next.set_map_id("next");
  next.mutable_scene()->set_name("two_level_ramp");
  EXPECT_EQ(CreateAndWait(next, 30).state(), v1::MAP_STATE_ACTIVE);
}

TEST_F(MapWorkerServerTest, AMapPastItsTimeFailsWithDeadlineExceeded) {
  // 10 ms: less than starting the worker process takes, so no map can be made in it on any
  // machine (hence no demo either: it would fail the same way).
  const std::string limit_s = "0.01";
  ASSERT_NO_FATAL_FAILURE(StartServer({"--no-preload", "--max-assessment-time-s", limit_s}));
  v1::Map map;
  const grpc::Status status = CreateSite("slow", true, &map);
  const CallError error = ErrorOf(status);
  EXPECT_EQ(error.code, grpc::StatusCode::DEADLINE_EXCEEDED) << error.message;
  EXPECT_EQ(error.reason, "TIME_BUDGET_EXCEEDED");
  EXPECT_THAT(error.message, HasSubstr("--max-assessment-time-s " + limit_s + " s"));
  EXPECT_TRUE(ChildrenOf(server_->pid()).empty());
  // The server answers on, and names the map's end.
  EXPECT_EQ(Get("slow").state(), v1::MAP_STATE_FAILED);
}

TEST_F(MapWorkerServerTest, AMapPastItsMemoryFailsWithResourceExhausted) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-assessment-memory", "67108864"}));
  v1::Map map;
  const CallError error = ErrorOf(CreateSite("huge", true, &map));
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED) << error.message;
  EXPECT_THAT(error.message, HasSubstr("--max-assessment-memory 64 MiB"));
  ExpectDemoPlans();
}

}  // namespace
}  // namespace strata::server::testing
