// Several real strata-server processes sharing one map store (--map-store): any replica
// serves any map, edits and deletions reach every replica, a killed writer leaves no half
// version, and a memory budget holds while maps are planned on in turn.
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <future>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "etcd_process.hpp"
#include "server_process.hpp"
#include "server_test_util.hpp"
#include "strata/scenes/outdoor_site.hpp"

namespace strata::server::testing {
namespace {

namespace fs = std::filesystem;

// A flat 24 m x 16 m floor sampled every 0.1 m: small enough to assess in a blink, open enough
// that a straight plan crosses its middle.
std::string FloorPoints() {
  std::vector<float> xyz;
  for (int ix = 0; ix <= 240; ++ix) {
    for (int iy = 0; iy <= 160; ++iy) xyz.insert(xyz.end(), {0.1f * ix, 0.1f * iy, 0.0f});
  }
  return std::string(reinterpret_cast<const char*>(xyz.data()), xyz.size() * sizeof(float));
}

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = fs::temp_directory_path() /
             ("strata-store-test-" + std::to_string(::getpid()) + "-" +
              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(store_);
  }
  void TearDown() override {
    for (const auto& server : servers_) {
      if (HasFailure() && server != nullptr) {
        std::fprintf(stderr, "--- strata-server log ---\n%s\n", server->Log().c_str());
      }
    }
    servers_.clear();
    fs::remove_all(store_);
  }

  // A replica on the shared store, SERVING.
  ServerProcess* StartReplica(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--no-preload", "--map-store", store_.string()};
    args.insert(args.end(), shared_.begin(), shared_.end());
    args.insert(args.end(), extra.begin(), extra.end());
    servers_.push_back(ServerProcess::Start(args));
    ServerProcess* server = servers_.back().get();
    EXPECT_NE(server, nullptr);
    if (server != nullptr) EXPECT_TRUE(server->WaitServing(std::chrono::seconds(60)));
    return server;
  }

  void ServesEditsAndDeletesOnAnyReplica();
  void ConcurrentEditsAllLand();

  // Flags every replica gets: with heads on etcd, --etcd (StoreOnEtcdTest).
  std::vector<std::string> shared_;

  static grpc::Status Upload(const ServerProcess& server, const std::string& id, v1::Map* map) {
    auto stub = v1::MapService::NewStub(server.NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    auto writer = stub->UploadMap(&context, map);
    v1::UploadMapRequest header = UploadHeader(id);
    header.mutable_header()->set_wait(true);
    writer->Write(header);
    v1::UploadMapRequest chunk;
    chunk.mutable_chunk()->set_points(FloorPoints());
    writer->Write(chunk);
    writer->WritesDone();
    return writer->Finish();
  }

  static grpc::Status Plan(const ServerProcess& server, const v1::PlanRequest& request,
                           v1::PlanResponse* response) {
    auto stub = v1::PlannerService::NewStub(server.NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 60);
    return stub->Plan(&context, request, response);
  }

  static grpc::Status Update(const ServerProcess& server, const v1::UpdateMapRequest& request,
                             v1::UpdateMapResponse* response) {
    auto stub = v1::MapService::NewStub(server.NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 60);
    return stub->UpdateMap(&context, request, response);
  }

  static grpc::Status Get(const ServerProcess& server, const std::string& id, v1::Map* map) {
    auto stub = v1::MapService::NewStub(server.NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 60);
    v1::GetMapRequest request;
    request.set_map_id(id);
    return stub->GetMap(&context, request, map);
  }

  fs::path store_;
  std::vector<std::unique_ptr<ServerProcess>> servers_;
};

// Across the floor, through its middle.
v1::PlanRequest AcrossTheFloor(const std::string& id) {
  return PlanRequestFor(id, 2, 8, 0.3, 22, 8, 0.3);
}

// The maps' heads on etcd (--etcd with --map-store): the same behaviour, no head file.
class StoreOnEtcdTest : public StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    etcd_ = EtcdProcess::Start();
    ASSERT_NE(etcd_, nullptr) << "a real etcd is needed (scripts/install-deps.sh installs it)";
    shared_ = {"--etcd", etcd_->endpoint()};
  }
  std::unique_ptr<EtcdProcess> etcd_;
};

TEST_F(StoreTest, AnyReplicaServesEditsAndDeletesEveryMap) { ServesEditsAndDeletesOnAnyReplica(); }

TEST_F(StoreOnEtcdTest, AnyReplicaServesEditsAndDeletesEveryMapWithHeadsOnEtcd) {
  ServesEditsAndDeletesOnAnyReplica();
  EXPECT_FALSE(fs::exists(store_ / "maps" / "floor" / "head")) << "a head file was written";
}

void StoreTest::ServesEditsAndDeletesOnAnyReplica() {
  ServerProcess* a = StartReplica();
  ServerProcess* b = StartReplica();
  ASSERT_TRUE(a != nullptr && b != nullptr);

  v1::Map uploaded;
  const grpc::Status upload = Upload(*a, "floor", &uploaded);
  ASSERT_TRUE(upload.ok()) << upload.error_message();
  ASSERT_EQ(uploaded.version().size(), 32u);
  const std::string v1 = uploaded.version();

  // B never saw the upload: it loads the map from the store and plans the same trajectory.
  v1::PlanRequest request = AcrossTheFloor("floor");
  request.mutable_options()->set_sample_dt_s(0.05);
  v1::PlanResponse on_a, on_b;
  ASSERT_TRUE(Plan(*a, request, &on_a).ok());
  const grpc::Status planned_b = Plan(*b, request, &on_b);
  ASSERT_TRUE(planned_b.ok()) << planned_b.error_message();
  EXPECT_EQ(on_a.map_version(), v1);
  EXPECT_EQ(on_b.map_version(), v1);
  EXPECT_EQ(on_a.trajectory().SerializeAsString(), on_b.trajectory().SerializeAsString());
  EXPECT_LT(ClosestApproach(on_a, 12, 8), 0.5);  // Straight through the middle.

  // B closes the middle with an obstacle; A plans on the new version, around it.
  v1::UpdateMapRequest edit;
  edit.set_map_id("floor");
  edit.set_base_version(v1);
  SetBox(edit.add_edits()->mutable_add_obstacle(), 11, 5, 13, 11, -0.1, 1.5);
  v1::UpdateMapResponse edited;
  const grpc::Status updated = Update(*b, edit, &edited);
  ASSERT_TRUE(updated.ok()) << updated.error_message();
  const std::string v2 = edited.map().version();
  EXPECT_NE(v2, v1);
  // The edited cloud is the version's source: its counts add up (raw = dropped + input).
  EXPECT_GT(edited.map().input_point_count(), uploaded.input_point_count());
  EXPECT_EQ(edited.map().raw_point_count(),
            edited.map().dropped_nonfinite_point_count() + edited.map().input_point_count());
  EXPECT_THAT(edited.map().versions(), ::testing::ElementsAre(v2, v1));
  v1::PlanResponse around;
  const grpc::Status planned_around = Plan(*a, request, &around);
  ASSERT_TRUE(planned_around.ok()) << planned_around.error_message();
  EXPECT_EQ(around.map_version(), v2);
  EXPECT_GT(ClosestApproach(around, 12, 8), 3.0);  // Around the box, not through it.

  // The old version is kept and may be pinned; an edit against it is refused as stale.
  v1::PlanRequest pinned = request;
  pinned.set_map_version(v1);
  v1::PlanResponse on_v1;
  ASSERT_TRUE(Plan(*a, pinned, &on_v1).ok());
  EXPECT_EQ(on_v1.map_version(), v1);
  EXPECT_EQ(on_v1.trajectory().SerializeAsString(), on_a.trajectory().SerializeAsString());
  v1::UpdateMapResponse stale;
  EXPECT_EQ(ErrorOf(Update(*a, edit, &stale)).reason, "MAP_CHANGED");
  pinned.set_map_version(std::string(32, '0'));
  const CallError gone = ErrorOf(Plan(*b, pinned, &on_v1));
  EXPECT_EQ(gone.reason, "MAP_VERSION_NOT_FOUND");
  EXPECT_THAT(gone.message, ::testing::HasSubstr(v2));

  // A keep-out zone on the map: a goal inside it is refused with its own reason.
  v1::UpdateMapRequest close;
  close.set_map_id("floor");
  SetBox(close.add_edits()->mutable_add_keep_out(), 20, 6, 23, 10, -1, 3);
  v1::UpdateMapResponse closed;
  ASSERT_TRUE(Update(*a, close, &closed).ok());
  EXPECT_EQ(closed.map().keep_out_size(), 1);
  EXPECT_EQ(ErrorOf(Plan(*b, request, &on_b)).reason, "GOAL_IN_KEEP_OUT");

  // Deleted on A: B refuses it on the next request.
  {
    auto stub = v1::MapService::NewStub(a->NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    v1::DeleteMapRequest remove;
    remove.set_map_id("floor");
    v1::DeleteMapResponse removed;
    ASSERT_TRUE(stub->DeleteMap(&context, remove, &removed).ok());
  }
  v1::Map after;
  EXPECT_EQ(ErrorOf(Get(*b, "floor", &after)).reason, "MAP_NOT_FOUND");
  EXPECT_EQ(ErrorOf(Plan(*b, request, &on_b)).reason, "MAP_NOT_FOUND");
}

// Edits without a base version apply to the current version whenever they land: four at once
// used to lose three with MAP_CHANGED and leave their versions on disk, listed nowhere.
TEST_F(StoreTest, ConcurrentEditsWithoutABaseVersionAllLandAndLeaveNothingBehind) {
  ConcurrentEditsAllLand();
}

TEST_F(StoreOnEtcdTest, ConcurrentEditsOnTwoReplicasAllLandWithHeadsOnEtcd) {
  ConcurrentEditsAllLand();
}

void StoreTest::ConcurrentEditsAllLand() {
  ServerProcess* a = StartReplica();
  ServerProcess* b = StartReplica();
  ASSERT_TRUE(a != nullptr && b != nullptr);
  v1::Map uploaded;
  ASSERT_TRUE(Upload(*a, "floor", &uploaded).ok());
  constexpr int kEdits = 4;
  std::vector<std::future<grpc::Status>> edits;
  for (int i = 0; i < kEdits; ++i) {
    edits.push_back(std::async(std::launch::async, [&, i] {
      v1::UpdateMapRequest edit;
      edit.set_map_id("floor");
      SetBox(edit.add_edits()->mutable_add_keep_out(), 2 + 5 * i, 1, 4 + 5 * i, 3, -1, 3);
      v1::UpdateMapResponse response;
      return Update(i % 2 == 0 ? *a : *b, edit, &response);
    }));
  }
  for (auto& edit : edits) {
    const grpc::Status status = edit.get();
    EXPECT_TRUE(status.ok()) << status.error_message();
  }
  v1::Map after;
  ASSERT_TRUE(Get(*a, "floor", &after).ok());
  EXPECT_EQ(after.keep_out_size(), kEdits);
  std::set<std::string> on_disk;
  for (const auto& entry : fs::directory_iterator(store_ / "maps" / "floor" / "versions")) {
    on_disk.insert(entry.path().filename().string());
  }
  EXPECT_EQ(on_disk, std::set<std::string>(after.versions().begin(), after.versions().end()));
}

// An edit used to run on the RPC thread to its end whatever the call's deadline: the client
// heard DEADLINE_EXCEEDED while the server published the version, and a retry applied it
// twice. Now what a client hears is what happened: an edit it gave up on is never published.
TEST_F(StoreTest, AnEditPastItsDeadlineIsPublishedOnlyIfItsClientHeardSo) {
  ServerProcess* a = StartReplica();
  ASSERT_TRUE(a != nullptr);
  v1::Map uploaded;
  ASSERT_TRUE(Upload(*a, "floor", &uploaded).ok());
  auto stub = v1::MapService::NewStub(a->NewChannel());
  int published = 0;
  int zones = 0;
  for (const bool obstacle : {true, false}) {
    v1::UpdateMapRequest edit;
    edit.set_map_id("floor");
    SetBox(obstacle ? edit.add_edits()->mutable_add_obstacle()
                    : edit.add_edits()->mutable_add_keep_out(),
           11, 5, 13, 11, -0.1, 1.5);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    v1::UpdateMapResponse response;
    const grpc::Status status = stub->UpdateMap(&context, edit, &response);
    if (status.ok()) {
      ++published;
      zones += obstacle ? 0 : 1;
    } else {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
    }
  }
  // Once the server has stopped, every call it saw has ended: what the store holds is final.
  a->Signal(SIGTERM);
  ASSERT_EQ(a->WaitExit(std::chrono::seconds(60)), 0);
  ServerProcess* b = StartReplica();
  ASSERT_TRUE(b != nullptr);
  v1::Map after;
  ASSERT_TRUE(Get(*b, "floor", &after).ok());
  EXPECT_EQ(after.versions_size(), 1 + published);
  EXPECT_EQ(after.keep_out_size(), zones);
  if (published == 0) EXPECT_EQ(after.version(), uploaded.version());
  int on_disk = 0;
  for ([[maybe_unused]] const auto& entry :
       fs::directory_iterator(store_ / "maps" / "floor" / "versions")) {
    ++on_disk;
  }
  EXPECT_EQ(on_disk, after.versions_size());
}

TEST_F(StoreTest, TwoReplicasCreatingOneMapAtOnceMakeOneVersion) {
  ServerProcess* a = StartReplica();
  ServerProcess* b = StartReplica();
  ASSERT_TRUE(a != nullptr && b != nullptr);
  const auto create = [](const ServerProcess* server) {
    auto stub = v1::MapService::NewStub(server->NewChannel());
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    v1::CreateMapRequest request;
    request.set_map_id("ramp");
    request.mutable_scene()->set_name("two_level_ramp");
    request.set_wait(true);
    v1::Map map;
    const grpc::Status status = stub->CreateMap(&context, request, &map);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return map;
  };
  auto on_a = std::async(std::launch::async, create, a);
  auto on_b = std::async(std::launch::async, create, b);
  const v1::Map map_a = on_a.get();
  const v1::Map map_b = on_b.get();
  EXPECT_EQ(map_a.version(), map_b.version());
  v1::Map listed;
  ASSERT_TRUE(Get(*a, "ramp", &listed).ok());
  EXPECT_THAT(listed.versions(), ::testing::ElementsAre(map_a.version()));

  // Created once, the id is taken for every replica.
  auto stub = v1::MapService::NewStub(b->NewChannel());
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::CreateMapRequest again;
  again.set_map_id("ramp");
  again.mutable_scene()->set_name("uneven_terrain");
  v1::Map ignored;
  EXPECT_EQ(ErrorOf(stub->CreateMap(&context, again, &ignored)).reason, "MAP_ALREADY_EXISTS");
}

TEST_F(StoreTest, AServerKilledWhileWritingLeavesTheWholeVersionOrNone) {
  ServerProcess* observer = StartReplica();
  ServerProcess* writer = StartReplica();
  ASSERT_TRUE(observer != nullptr && writer != nullptr);
  // A map large enough that writing its version takes a while: kill the writer as it starts.
  auto stub = v1::MapService::NewStub(writer->NewChannel());
  grpc::ClientContext context;
  SetDeadline(&context, 120);
  v1::CreateMapRequest request;
  request.set_map_id("site");
  request.mutable_scene()->set_name("outdoor_site");
  request.mutable_scene()->set_size_m(120);
  v1::Map created;
  ASSERT_TRUE(stub->CreateMap(&context, request, &created).ok());
  ASSERT_TRUE(writer->WaitForLog("map_version_writing", std::chrono::seconds(120)))
      << writer->Log();
  writer->Signal(SIGKILL);
  EXPECT_EQ(writer->WaitExit(std::chrono::seconds(30)), -1);  // Died of the signal.

  // Whatever the observer and a restarted replica see is whole: no map, or one that plans
  // the site's own query, on the ground from end to end.
  ServerProcess* restarted = StartReplica();
  ASSERT_NE(restarted, nullptr);
  const OutdoorSiteLayout layout = GetOutdoorSiteLayout(1, 120);
  ASSERT_FALSE(layout.queries.empty());
  const SceneQuery& query = layout.queries.front();
  for (const ServerProcess* server : {observer, restarted}) {
    v1::Map map;
    const grpc::Status got = Get(*server, "site", &map);
    if (got.ok()) {
      EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE);
      EXPECT_GT(map.valid_surface_count(), 0u);
      v1::PlanRequest plan =
          PlanRequestFor("site", query.start_m.x(), query.start_m.y(), query.start_m.z() + 0.3,
                         query.goal_m.x(), query.goal_m.y(), query.goal_m.z() + 0.3);
      plan.mutable_options()->set_time_budget_s(30);
      v1::PlanResponse planned;
      const grpc::Status status = Plan(*server, plan, &planned);
      EXPECT_TRUE(status.ok()) << query.name << ": " << status.error_message();
      EXPECT_GT(planned.trajectory().pieces_size(), 0);
    } else {
      EXPECT_EQ(ErrorOf(got).reason, "MAP_NOT_FOUND") << got.error_message();
    }
  }
  // And the id can be created again from scratch when it was lost.
  v1::Map map;
  if (!Get(*restarted, "site", &map).ok()) {
    auto again = v1::MapService::NewStub(restarted->NewChannel());
    grpc::ClientContext again_context;
    SetDeadline(&again_context, 180);
    request.set_wait(true);
    request.mutable_scene()->set_size_m(40);  // Any map will do: what matters is the id.
    const grpc::Status recreated = again->CreateMap(&again_context, request, &map);
    EXPECT_TRUE(recreated.ok()) << recreated.error_message();
  }
}

TEST_F(StoreTest, MapsBeyondTheMemoryBudgetArePlannedOnInTurn) {
  // Four maps written to the store by one replica, planned on by another that can hold about
  // two of them.
  ServerProcess* writer = StartReplica();
  ASSERT_NE(writer, nullptr);
  std::uint64_t largest = 0;
  for (int i = 0; i < 4; ++i) {
    v1::Map map;
    const grpc::Status uploaded = Upload(*writer, "floor" + std::to_string(i), &map);
    ASSERT_TRUE(uploaded.ok()) << uploaded.error_message();
    v1::PlanResponse response;
    ASSERT_TRUE(Plan(*writer, AcrossTheFloor(map.id()), &response).ok());
    ASSERT_TRUE(Get(*writer, map.id(), &map).ok());
    largest = std::max<std::uint64_t>(largest, map.memory_bytes());
  }
  const std::uint64_t budget = 2 * largest + largest / 2;
  ServerProcess* reader = StartReplica({"--max-memory", std::to_string(budget)});
  ASSERT_NE(reader, nullptr);
  for (int round = 0; round < 2; ++round) {
    for (int i = 0; i < 4; ++i) {
      v1::PlanResponse response;
      const grpc::Status planned =
          Plan(*reader, AcrossTheFloor("floor" + std::to_string(i)), &response);
      EXPECT_TRUE(planned.ok()) << planned.error_message();
      const std::string metrics = HttpGet(reader->metrics_port(), "/metrics");
      const double resident = MetricValue(metrics, "strata_map_memory_bytes", {});
      EXPECT_GT(resident, 0);
      EXPECT_LE(resident, static_cast<double>(budget)) << "after planning on floor" << i;
      EXPECT_EQ(MetricValue(metrics, "strata_memory_budget_bytes", {}),
                static_cast<double>(budget));
    }
  }
}

}  // namespace
}  // namespace strata::server::testing
