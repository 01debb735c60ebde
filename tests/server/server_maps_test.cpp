// MapService end to end against the real strata-server binary.
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <grpc/health/v1/health.grpc.pb.h>
#include <Eigen/Geometry>

#include "server_fixture.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/scenes/map_source.hpp"
#include "test_util/run_command.hpp"

namespace strata::server::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

class MapServiceTest : public ServerFixture {};

TEST_F(MapServiceTest, StartsServingWithTheDemoMapAndPerServiceHealth) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  auto health = grpc::health::v1::Health::NewStub(channel_);
  for (const char* service : {"", "strata.v1.MapService", "strata.v1.PlannerService"}) {
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    grpc::health::v1::HealthCheckRequest request;
    request.set_service(service);
    grpc::health::v1::HealthCheckResponse response;
    ASSERT_TRUE(health->Check(&context, request, &response).ok()) << service;
    EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING) << service;
  }
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_map_id("demo");
  v1::Map demo;
  ASSERT_TRUE(maps_->GetMap(&context, request, &demo).ok());
  EXPECT_EQ(demo.state(), v1::MAP_STATE_ACTIVE);
  EXPECT_EQ(demo.source().scene().name(), "two_level_ramp");
  // kDefaultSceneSeed and the scene's own spacing, as strata-offline's scene:two_level_ramp.
  EXPECT_EQ(demo.source().scene().seed(), 1u);
  EXPECT_EQ(demo.source().scene().spacing_m(), 0.1);
  EXPECT_FALSE(demo.source().scene().has_size_m());  // No size parameter.
  EXPECT_EQ(demo.max_levels(), 2u);                  // Floor and deck.
  EXPECT_GT(demo.memory_bytes(), 0u);
  EXPECT_GT(demo.assessment_seconds().total_s(), 0);
  EXPECT_TRUE(demo.has_done_time());
}

TEST_F(MapServiceTest, APreloadThatFailsEndsTheServerWhenAskedTo) {
  server_ = ServerProcess::Start(
      {"--map-root", TestMapRoot(), "--preload", "bad=README.md", "--exit-on-preload-failure"});
  ASSERT_NE(server_, nullptr);
  EXPECT_EQ(server_->WaitExit(std::chrono::seconds(60)), 1);
  EXPECT_THAT(server_->Log(), HasSubstr("event=preload_failed map=bad"));
}

TEST_F(MapServiceTest, HealthStaysNotServingWhenAPreloadFails) {
  // README.md is under the map root but is no point cloud: its assessment fails.
  server_ = ServerProcess::Start({"--map-root", TestMapRoot(), "--preload",
                                  "demo=scene:two_level_ramp", "--preload", "bad=README.md"});
  ASSERT_NE(server_, nullptr);
  ASSERT_TRUE(server_->WaitForLog("event=preload_failed map=bad", std::chrono::seconds(60)));
  channel_ = server_->NewChannel();
  auto health = grpc::health::v1::Health::NewStub(channel_);
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  grpc::health::v1::HealthCheckResponse response;
  ASSERT_TRUE(health->Check(&context, grpc::health::v1::HealthCheckRequest(), &response).ok());
  EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::NOT_SERVING);

  maps_ = v1::MapService::NewStub(channel_);
  grpc::ClientContext get_context;
  v1::GetMapRequest request;
  request.set_map_id("bad");
  v1::Map bad;
  ASSERT_TRUE(maps_->GetMap(&get_context, request, &bad).ok());
  EXPECT_EQ(bad.state(), v1::MAP_STATE_FAILED);
  EXPECT_EQ(bad.failure().reason(), "MAP_LOAD_FAILED");
  EXPECT_THAT(bad.failure().message(), HasSubstr("README.md"));
  EXPECT_THAT(bad.failure().message(), ::testing::Not(HasSubstr(TestMapRoot())));
}

TEST_F(MapServiceTest, CreatesGetsListsPagesAndDeletes) {
  if (!HaveSpiral()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::CreateMapRequest scene;
  scene.set_map_id("hills");
  scene.mutable_scene()->set_name("uneven_terrain");
  scene.mutable_scene()->set_seed(3);
  scene.mutable_terrain()->set_resolution_m(0.25);
  const v1::Map hills = CreateAndWait(scene);
  EXPECT_EQ(hills.terrain().resolution_m(), 0.25);
  EXPECT_EQ(hills.terrain().ground_radius_m(), 0.3);  // Defaults filled in.

  const v1::Map spiral = CreateSpiral();
  EXPECT_EQ(spiral.source().file().path(), "spiral0.3_2.pcd");
  EXPECT_EQ(spiral.raw_point_count(), 231885u);
  EXPECT_GE(spiral.max_levels(), 5u);  // Ramps stacked over the ground floor.
  EXPECT_GT(spiral.grid_size().nz(), 60);
  EXPECT_NEAR(spiral.bounds_m().max_m().z(), 22.8, 0.1);

  // Pages of one: demo, hills, spiral in id order, then no token.
  std::vector<std::string> ids;
  std::string token;
  int pages = 0;
  do {
    grpc::ClientContext context;
    v1::ListMapsRequest request;
    request.set_page_size(1);
    request.set_page_token(token);
    v1::ListMapsResponse response;
    ASSERT_TRUE(maps_->ListMaps(&context, request, &response).ok());
    for (const v1::Map& map : response.maps()) ids.push_back(map.id());
    token = response.next_page_token();
    ASSERT_LE(++pages, 3);
  } while (!token.empty());
  EXPECT_THAT(ids, ElementsAre("demo", "hills", "spiral"));

  {
    grpc::ClientContext context;
    v1::ListMapsRequest request;
    request.set_page_token("garbage");
    v1::ListMapsResponse response;
    const CallError error = ErrorOf(maps_->ListMaps(&context, request, &response));
    EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(error.fields, ElementsAre("page_token"));
  }
  {
    grpc::ClientContext context;
    v1::DeleteMapRequest request;
    request.set_map_id("hills");
    v1::DeleteMapResponse response;
    ASSERT_TRUE(maps_->DeleteMap(&context, request, &response).ok());
  }
  grpc::ClientContext context;
  v1::GetMapRequest request;
  request.set_map_id("hills");
  v1::Map map;
  const CallError error = ErrorOf(maps_->GetMap(&context, request, &map));
  EXPECT_EQ(error.code, grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(error.reason, "MAP_NOT_FOUND");
  EXPECT_EQ(error.domain, "strata");
}

TEST_F(MapServiceTest, CreateWithoutWaitReturnsAtOnce) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  grpc::ClientContext context;
  v1::CreateMapRequest request;
  request.mutable_scene()->set_name("stairs_ramp_room");
  v1::Map map;
  ASSERT_TRUE(maps_->CreateMap(&context, request, &map).ok());
  EXPECT_THAT(map.id(), ::testing::StartsWith("map-"));
  EXPECT_EQ(map.state(), v1::MAP_STATE_CREATING);
  EXPECT_LT(map.progress(), 1.0);
  EXPECT_FALSE(map.has_done_time());
}

// Two flat 60 m x 60 m floors 10 m apart, sampled every 0.13 m (426k points, 5.1 MB): more
// than gRPC's 4 MiB message limit, and two disconnected components.
std::vector<float> TwoFloors() {
  std::vector<float> xyz;
  for (const float x0 : {0.0f, 70.0f}) {
    for (int i = 0; i < 462; ++i) {
      for (int j = 0; j < 462; ++j) {
        xyz.insert(xyz.end(), {x0 + 0.13f * i, 0.13f * j, 0.0f});
      }
    }
  }
  return xyz;
}

TEST_F(MapServiceTest, UploadsACloudFarAboveTheMessageLimitInChunks) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  std::vector<float> xyz = TwoFloors();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  xyz.insert(xyz.end(), {nan, 0, 0, 1, nan, 1});  // Dropped and counted.
  const std::size_t points = xyz.size() / 3;
  ASSERT_GT(xyz.size() * sizeof(float), std::size_t{4} << 20);

  grpc::ClientContext context;
  SetDeadline(&context, 120);
  v1::Map map;
  auto writer = maps_->UploadMap(&context, &map);
  v1::UploadMapRequest header = UploadHeader("floors", points);
  header.mutable_header()->set_wait(true);
  ASSERT_TRUE(writer->Write(header));
  const std::size_t chunk_points = (std::size_t{1} << 20) / 12;  // The largest chunk allowed.
  int chunks = 0;
  for (std::size_t first = 0; first < points; first += chunk_points) {
    const std::size_t count = std::min(chunk_points, points - first);
    v1::UploadMapRequest chunk;
    chunk.mutable_chunk()->set_points(
        std::string(reinterpret_cast<const char*>(&xyz[3 * first]), count * 12));
    ASSERT_TRUE(writer->Write(chunk));
    ++chunks;
  }
  ASSERT_TRUE(writer->WritesDone());
  const grpc::Status status = writer->Finish();
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GE(chunks, 5);
  EXPECT_EQ(map.id(), "floors");
  EXPECT_EQ(map.state(), v1::MAP_STATE_ACTIVE);
  EXPECT_EQ(map.raw_point_count(), points);
  EXPECT_EQ(map.dropped_nonfinite_point_count(), 2u);
  EXPECT_EQ(map.source().upload().received_bytes(), points * 12);

  v1::PlanResponse response;
  const grpc::Status within = Plan(PlanRequestFor("floors", 5, 5, 0.3, 50, 50, 0.3), &response);
  EXPECT_TRUE(within.ok()) << within.error_message();
  const CallError across =
      ErrorOf(Plan(PlanRequestFor("floors", 5, 5, 0.3, 100, 50, 0.3), &response));
  EXPECT_EQ(across.code, grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(across.reason, "GOAL_UNREACHABLE");
}

TEST_F(MapServiceTest, RefusesMalformedUploads) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::Map map;
  auto writer = maps_->UploadMap(&context, &map);
  writer->Write(UploadHeader("broken"));
  v1::UploadMapRequest chunk;
  chunk.mutable_chunk()->set_points(std::string(13, '\0'));  // Not whole 12-byte points.
  writer->Write(chunk);
  writer->WritesDone();
  const CallError error = ErrorOf(writer->Finish());
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "MAP_LOAD_FAILED");
  EXPECT_THAT(error.fields, ElementsAre("chunk.points"));
  EXPECT_THAT(error.message, HasSubstr("12-byte"));

  grpc::ClientContext get_context;
  v1::GetMapRequest get;
  get.set_map_id("broken");
  EXPECT_EQ(maps_->GetMap(&get_context, get, &map).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(MapServiceTest, AChunkAboveTheMessageLimitIsResourceExhaustedAndTheLogSaysWhy) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::Map map;
  auto writer = maps_->UploadMap(&context, &map);
  writer->Write(UploadHeader("huge"));
  v1::UploadMapRequest chunk;
  chunk.mutable_chunk()->set_points(std::string(5 << 20, '\0'));  // Above 4 MiB.
  writer->Write(chunk);
  writer->WritesDone();
  const CallError error = ErrorOf(writer->Finish());
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED) << error.message;
  // The server's log names the cause, not only a consequence of it ("no points").
  ASSERT_TRUE(server_->WaitForLog("rpc=UploadMap map=huge", std::chrono::seconds(10)));
  const std::string log = server_->Log();
  std::string line = log.substr(log.find("rpc=UploadMap map=huge"));
  line = line.substr(0, line.find('\n'));
  // gRPC has ended the stream by the time the server reads on: whether it has also marked the
  // call cancelled yet is a race, and either way the log names the limit.
  EXPECT_THAT(line, HasSubstr("larger than --max-receive-message-bytes"));
}

TEST_F(MapServiceTest, RefusesPathsOutsideTheMapRoot) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  for (const char* path :
       {"../DESIGN.md", "/etc/passwd", "../../../etc/passwd", "../maps/../STYLE.md"}) {
    grpc::ClientContext context;
    v1::CreateMapRequest request;
    request.set_map_id("escape");
    request.mutable_file()->set_path(path);
    v1::Map map;
    const CallError error = ErrorOf(maps_->CreateMap(&context, request, &map));
    EXPECT_EQ(error.code, grpc::StatusCode::PERMISSION_DENIED) << path;
    EXPECT_EQ(error.reason, "PATH_OUTSIDE_MAP_ROOT") << path;
    EXPECT_THAT(error.fields, ElementsAre("file.path"));
  }
  grpc::ClientContext context;
  v1::CreateMapRequest request;
  request.mutable_file()->set_path("no_such_map.pcd");
  v1::Map map;
  const CallError missing = ErrorOf(maps_->CreateMap(&context, request, &map));
  EXPECT_EQ(missing.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(missing.reason, "MAP_LOAD_FAILED");
}

// A link in the map root that points out of it was refused when named directly but read
// when the path reached it through a directory that does not exist ("missing/../link.pcd"):
// the check resolved the text, the worker opened the link. Now the file is opened once and
// the opened file's real path decides, for CreateMap and --preload alike.
TEST_F(MapServiceTest, ALinkOutOfTheMapRootIsRefusedHoweverThePathReachesIt) {
  namespace fs = std::filesystem;
  const fs::path base =
      fs::temp_directory_path() / ("strata_link_root_" + std::to_string(::getpid()));
  fs::remove_all(base);
  fs::create_directories(base / "root" / "sub");
  fs::create_directories(base / "outside");
  Expected<LoadedCloud> cloud = strata::LoadMapSource(SceneSource{"two_level_ramp", 1});
  ASSERT_TRUE(cloud.ok());
  ASSERT_TRUE(SavePcd(cloud->points, (base / "outside" / "secret.pcd").string()).ok());
  fs::create_symlink(base / "outside" / "secret.pcd", base / "root" / "link.pcd");
  fs::create_directory_symlink(base / "outside", base / "root" / "linked_dir");
  server_ = ServerProcess::Start({"--map-root", (base / "root").string(), "--no-preload"});
  ASSERT_NE(server_, nullptr);
  maps_ = v1::MapService::NewStub(server_->NewChannel());
  int n = 0;
  for (const char* path : {"link.pcd", "./link.pcd", "missing/../link.pcd", "sub/../link.pcd",
                           "sub/./../link.pcd", "sub/../../root/link.pcd", "linked_dir/secret.pcd",
                           "missing/../linked_dir/secret.pcd", "sub/../linked_dir/secret.pcd"}) {
    grpc::ClientContext context;
    SetDeadline(&context, 60);
    v1::CreateMapRequest request;
    request.set_map_id("escape-" + std::to_string(n++));
    request.mutable_file()->set_path(path);
    request.set_wait(true);
    v1::Map map;
    const grpc::Status status = maps_->CreateMap(&context, request, &map);
    ASSERT_FALSE(status.ok()) << path << " was read: " << map.ShortDebugString();
    const CallError error = ErrorOf(status);
    EXPECT_TRUE(error.reason == "PATH_OUTSIDE_MAP_ROOT" || error.reason == "MAP_LOAD_FAILED")
        << path << ": " << error.reason << " " << error.message;
  }
  // --preload resolves its paths the same way: the server does not start.
  const auto preload = test_util::RunCommand(
      {STRATA_SERVER_BINARY, "--listen", "127.0.0.1:0", "--metrics-port", "-1", "--map-root",
       (base / "root").string(), "--preload", "x=sub/../link.pcd"});
  EXPECT_EQ(preload.exit_code, 1);
  EXPECT_THAT(preload.err, HasSubstr("outside the server's map root"));
  fs::remove_all(base);
}

TEST_F(MapServiceTest, RefusesBadRequestsNamingTheField) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  auto scene = [](const char* name) {
    v1::CreateMapRequest request;
    request.mutable_scene()->set_name(name);
    return request;
  };
  struct Case {
    v1::CreateMapRequest request;
    grpc::StatusCode code;
    std::string reason;
    std::string field;
  };
  std::vector<Case> cases = {
      {scene("moon"), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_INPUT", "scene.name"},
      {scene("two_level_ramp"), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_CONFIG",
       "terrain.resolution_m"},
      {scene("two_level_ramp"), grpc::StatusCode::ALREADY_EXISTS, "MAP_ALREADY_EXISTS", ""},
      {v1::CreateMapRequest(), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_INPUT", "source"},
      {scene("two_level_ramp"), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_INPUT", "map_id"},
      {scene("two_level_ramp"), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_INPUT",
       "scene.size_m"},
      {scene("outdoor_site"), grpc::StatusCode::INVALID_ARGUMENT, "INVALID_INPUT",
       "scene.spacing_m"},
      {scene("outdoor_site"), grpc::StatusCode::RESOURCE_EXHAUSTED, "RESOURCE_EXHAUSTED",
       "scene.spacing_m"},
  };
  cases[1].request.mutable_terrain()->set_resolution_m(100);
  cases[2].request.set_map_id("demo");
  cases[4].request.set_map_id("../demo");
  cases[5].request.mutable_scene()->set_size_m(50);  // A scene without a size parameter.
  cases[6].request.mutable_scene()->set_spacing_m(0.001);
  // 1 km at 2 cm: 2.5e9 points, refused before anything is generated.
  cases[7].request.mutable_scene()->set_size_m(1000);
  cases[7].request.mutable_scene()->set_spacing_m(0.02);
  for (const Case& c : cases) {
    grpc::ClientContext context;
    v1::Map map;
    const CallError error = ErrorOf(maps_->CreateMap(&context, c.request, &map));
    EXPECT_EQ(error.code, c.code) << c.reason;
    EXPECT_EQ(error.reason, c.reason);
    if (!c.field.empty()) EXPECT_THAT(error.fields, ElementsAre(c.field));
  }
}

TEST_F(MapServiceTest, ServesASavedModelAsSavedAndPlansOnItAsOnTheScene) {
  // A model saved by the offline library into a map root of its own.
  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("strata-saved-root-" + std::to_string(::getpid()));
  fs::create_directories(root);
  {
    Expected<LoadedCloud> cloud = strata::LoadMapSource(SceneSource{"two_level_ramp"});
    ASSERT_TRUE(cloud.ok());
    auto model = TerrainModel::Assess(cloud->points, AssessmentConfig{});
    ASSERT_TRUE(model.ok());
    ASSERT_TRUE(SaveModel(**model, (root / "ramp.stratamodel").string()).ok());
  }
  server_ = ServerProcess::Start({"--map-root", root.string(), "--no-preload"});
  ASSERT_NE(server_, nullptr);
  ASSERT_TRUE(server_->WaitServing(std::chrono::seconds(60))) << server_->Log();
  channel_ = server_->NewChannel();
  maps_ = v1::MapService::NewStub(channel_);
  planner_ = v1::PlannerService::NewStub(channel_);

  v1::CreateMapRequest saved;
  saved.set_map_id("saved");
  saved.mutable_file()->set_path("ramp.stratamodel");
  const v1::Map map = CreateAndWait(saved);
  EXPECT_TRUE(map.from_saved_model());
  EXPECT_DOUBLE_EQ(map.terrain().resolution_m(), 0.2);
  EXPECT_GT(map.valid_surface_count(), 0u);
  v1::CreateMapRequest scene;
  scene.set_map_id("scene");
  scene.mutable_scene()->set_name("two_level_ramp");
  EXPECT_FALSE(CreateAndWait(scene).from_saved_model());

  // Floor to deck on both: the same trajectory.
  v1::PlanResponse on_saved, on_scene;
  ASSERT_TRUE(Plan(PlanRequestFor("saved", 2, 2, 0.3, 10, 10, 3.3), &on_saved).ok());
  ASSERT_TRUE(Plan(PlanRequestFor("scene", 2, 2, 0.3, 10, 10, 3.3), &on_scene).ok());
  EXPECT_EQ(on_saved.trajectory().SerializeAsString(), on_scene.trajectory().SerializeAsString());

  // Other terrain parameters for a saved model: refused at once, saying why.
  v1::CreateMapRequest other = saved;
  other.set_map_id("other");
  other.mutable_terrain()->set_resolution_m(0.3);
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::Map unused;
  const CallError error = ErrorOf(maps_->CreateMap(&context, other, &unused));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.message, HasSubstr("saved model"));
  EXPECT_THAT(error.message, HasSubstr("grid.resolution_m"));
  EXPECT_THAT(error.fields, ElementsAre("terrain"));
  fs::remove_all(root);
}

// ---------------------------------------------------------------------------------------------
// Scans (UpdateMap's MapEdit.scan) end to end: converted, sent to the worker with the edit,
// applied and reassessed there, published in the store, planned on.

// Points packed as MapEdit.scan.points and PointChunk.points are (float32 x, y, z; the
// machines these tests run on are little-endian, as the other upload tests assume).
std::string Packed(const std::vector<float>& xyz) {
  return std::string(reinterpret_cast<const char*>(xyz.data()), xyz.size() * sizeof(float));
}

// A 24 m x 16 m room sampled every 0.1 m: its floor at z = 0 and 2 m walls, every point off
// by up to 1 cm in height (seeded) as a sensor's are, so the map is no voxel lattice.
std::string RoomPoints() {
  std::mt19937 random(43);
  std::uniform_real_distribution<float> noise(-0.01f, 0.01f);
  std::vector<float> xyz;
  for (int ix = 0; ix <= 240; ++ix) {
    for (int iy = 0; iy <= 160; ++iy) {
      xyz.insert(xyz.end(), {0.1f * ix, 0.1f * iy, noise(random)});
      const bool wall = ix == 0 || ix == 240 || iy == 0 || iy == 160;
      for (int iz = 1; wall && iz <= 20; ++iz) {
        xyz.insert(xyz.end(), {0.1f * ix, 0.1f * iy, 0.1f * iz + noise(random)});
      }
    }
  }
  return Packed(xyz);
}

// What a robot sees of the floor over [x0, x1] x [y0, y1] (a point every 5 cm, off by up to
// 5 mm) and, when `pallets` is not empty, of a pallet stack standing there (its top and sides
// every 2 cm, finer than the map's thinning), packed for MapEdit.scan.points.
std::string ScanPoints(double x0, double y0, double x1, double y1,
                       const Eigen::AlignedBox3d& pallets, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> noise(-0.005, 0.005);
  std::vector<float> xyz;
  const auto add = [&](double x, double y, double z) {
    xyz.insert(xyz.end(),
               {static_cast<float>(x + noise(random)), static_cast<float>(y + noise(random)),
                static_cast<float>(z + noise(random))});
  };
  for (double x = x0; x <= x1; x += 0.05) {
    for (double y = y0; y <= y1; y += 0.05) {
      if (pallets.isEmpty() || !pallets.contains(Eigen::Vector3d(x, y, pallets.center().z()))) {
        add(x, y, 0);
      }
    }
  }
  if (!pallets.isEmpty()) {
    const Eigen::Vector3d lo = pallets.min(), hi = pallets.max();
    for (double x = lo.x(); x <= hi.x(); x += 0.02) {
      for (double y = lo.y(); y <= hi.y(); y += 0.02) add(x, y, hi.z());
      for (double z = lo.z(); z < hi.z(); z += 0.02) {
        add(x, lo.y(), z);
        add(x, hi.y(), z);
      }
    }
    for (double y = lo.y(); y <= hi.y(); y += 0.02) {
      for (double z = lo.z(); z < hi.z(); z += 0.02) {
        add(lo.x(), y, z);
        add(hi.x(), y, z);
      }
    }
  }
  return Packed(xyz);
}

namespace fs = std::filesystem;

class ScanTest : public MapServiceTest {
 protected:
  void SetUp() override {
    store_ = fs::temp_directory_path() / ("strata-scan-test-" + std::to_string(::getpid()));
    fs::remove_all(store_);
    ASSERT_NO_FATAL_FAILURE(StartServer({"--no-preload", "--map-store", store_.string()}));
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    auto writer = maps_->UploadMap(&context, &room_);
    v1::UploadMapRequest header = UploadHeader("room");
    header.mutable_header()->set_wait(true);
    writer->Write(header);
    v1::UploadMapRequest chunk;
    const std::string points = RoomPoints();
    for (std::size_t at = 0; at < points.size(); at += 1020 * 1020) {  // 1 MiB, whole points.
      chunk.mutable_chunk()->set_points(points.substr(at, 1020 * 1020));
      writer->Write(chunk);
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  void TearDown() override {
    MapServiceTest::TearDown();
    fs::remove_all(store_);
  }

  grpc::Status Update(const v1::UpdateMapRequest& request, v1::UpdateMapResponse* response) {
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    return maps_->UpdateMap(&context, request, response);
  }

  // Across the room through its middle, sampled finely enough to see a detour.
  static v1::PlanRequest AcrossTheRoom() {
    v1::PlanRequest request = PlanRequestFor("room", 2, 8, 0.3, 22, 8, 0.3);
    request.mutable_options()->set_sample_dt_s(0.05);
    return request;
  }

  fs::path store_;
  v1::Map room_;
};

TEST_F(ScanTest, APalletStackScannedInTheAisleIsPlannedAroundAndABareFloorScanClearsIt) {
  v1::PlanResponse straight;
  const grpc::Status planned = Plan(AcrossTheRoom(), &straight);
  ASSERT_TRUE(planned.ok()) << planned.error_message();
  EXPECT_LT(ClosestApproach(straight, 12, 8), 0.5);  // Straight through the middle.

  // A robot scanned the middle of the room: a 1.2 m x 10 m row of pallets, 1.2 m high, stands
  // across the aisle; it saw the floor 1 m past the region it vouches for.
  const Eigen::AlignedBox3d pallets(Eigen::Vector3d(11.4, 3, 0), Eigen::Vector3d(12.6, 13, 1.2));
  v1::UpdateMapRequest scan;
  scan.set_map_id("room");
  scan.set_base_version(room_.version());
  v1::Scan* seen = scan.add_edits()->mutable_scan();
  SetBox(seen->mutable_region(), 10, 2, 14, 14, -0.2, 1.6);
  seen->set_points(ScanPoints(9, 1, 15, 15, pallets, 1));
  ASSERT_LT(scan.ByteSizeLong(), std::size_t{4} << 20);  // One message.
  v1::UpdateMapResponse scanned;
  grpc::Status updated = Update(scan, &scanned);
  ASSERT_TRUE(updated.ok()) << updated.error_message();
  EXPECT_NE(scanned.map().version(), room_.version());
  EXPECT_FALSE(scanned.stats().full_reassessment()) << scanned.stats().full_reassessment_reason();
  EXPECT_GT(scanned.stats().scan_points_outside_region(), 0u);
  EXPECT_GT(scanned.stats().scan_points_thinned(), 0u);
  EXPECT_EQ(scanned.stats().merged_updates(), 1);  // Alone: no other edit arrived meanwhile.
  // Made from the store's tiles around the scan, not the whole version, and joined here.
  EXPECT_TRUE(scanned.stats().from_tiles());
  EXPECT_EQ(scanned.stats().load_s(), 0);
  EXPECT_GT(scanned.stats().join_s(), 0);
  // The map keeps its grid (the scan lies within the room's points): only the columns around
  // the scan were assessed again.
  EXPECT_EQ(scanned.map().grid_size().SerializeAsString(), room_.grid_size().SerializeAsString());
  EXPECT_EQ(scanned.map().grid_origin_m().SerializeAsString(),
            room_.grid_origin_m().SerializeAsString());

  v1::PlanResponse around;
  const grpc::Status planned_around = Plan(AcrossTheRoom(), &around);
  ASSERT_TRUE(planned_around.ok()) << planned_around.error_message();
  EXPECT_EQ(around.map_version(), scanned.map().version());
  EXPECT_GT(ClosestApproach(around, 12, 8), 4.0);  // Around the row's end, not through it.

  // The pallets are gone: a scan of the bare floor clears them, and the plan is straight again.
  v1::UpdateMapRequest bare = scan;
  bare.set_base_version(scanned.map().version());
  bare.mutable_edits(0)->mutable_scan()->set_points(
      ScanPoints(10, 2, 14, 14, Eigen::AlignedBox3d(), 2));
  v1::UpdateMapResponse cleared;
  updated = Update(bare, &cleared);
  ASSERT_TRUE(updated.ok()) << updated.error_message();
  v1::PlanResponse again;
  ASSERT_TRUE(Plan(AcrossTheRoom(), &again).ok());
  EXPECT_EQ(again.map_version(), cleared.map().version());
  EXPECT_LT(ClosestApproach(again, 12, 8), 0.5);
}

TEST_F(ScanTest, AScanPastTheMapOrWithBadPointsIsRefusedAndTheMapStaysAsItWas) {
  // Its region reaches 6 m past the room's east wall, beyond the map's grid.
  v1::UpdateMapRequest past;
  past.set_map_id("room");
  SetBox(past.add_edits()->mutable_scan()->mutable_region(), 20, 6, 30, 10, -0.2, 1.6);
  past.mutable_edits(0)->mutable_scan()->set_points(
      ScanPoints(20, 6, 30, 10, Eigen::AlignedBox3d(), 3));
  v1::UpdateMapResponse response;
  CallError error = ErrorOf(Update(past, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.reason, "INVALID_INPUT");
  EXPECT_THAT(error.message,
              HasSubstr("edits[0].region spans (20.00, 6.00, -0.20) – (30.00, 10.00, 1.60) m, "
                        "beyond the map's grid ("));
  const v1::Vector3& origin = room_.grid_origin_m();
  EXPECT_THAT(error.message, HasSubstr(fmt::format("grid ({:.2f}, {:.2f}, {:.2f}) – (", origin.x(),
                                                   origin.y(), origin.z())));

  // A point that is not finite: refused before any work, naming the field and the point.
  std::string points = ScanPoints(10, 6, 12, 10, Eigen::AlignedBox3d(), 4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(points.data() + 5 * 12 + 8, &nan, sizeof(nan));  // Point 5's z.
  v1::UpdateMapRequest not_finite;
  not_finite.set_map_id("room");
  SetBox(not_finite.add_edits()->mutable_scan()->mutable_region(), 10, 6, 12, 10, -0.2, 1.6);
  not_finite.mutable_edits(0)->mutable_scan()->set_points(points);
  error = ErrorOf(Update(not_finite, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ElementsAre("edits[0].scan.points"));
  EXPECT_THAT(error.message, HasSubstr("not finite at index 5"));

  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::GetMapRequest get;
  get.set_map_id("room");
  v1::Map now;
  ASSERT_TRUE(maps_->GetMap(&context, get, &now).ok());
  EXPECT_EQ(now.version(), room_.version());
}

}  // namespace
}  // namespace strata::server::testing
