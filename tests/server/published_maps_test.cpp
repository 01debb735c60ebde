// The two homes of published maps keep one contract: the same answers from memory and from
// the map store, but for what only a store can do (edits, letting a map go and loading it
// again).
#include "maps/published_maps.hpp"

#include <unistd.h>

#include <filesystem>
#include <map>
#include <mutex>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/free_memory.hpp"
#include "maps/map_store.hpp"
#include "maps/memory_maps.hpp"
#include "maps/stored_maps.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A flat floor 3 m wide and `rows` x 5 cm long (3 m by default) sampled every 5 cm, `height` m
// up, with a 0.5 m x 0.5 m hole at its origin when `hole`: assessed in milliseconds.
std::shared_ptr<const PlanningMap> FloorAt(float height, PointCloud* cloud, int rows = 60,
                                           bool hole = false) {
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < rows; ++j) {
      if (!(hole && i < 10 && j < 10)) cloud->emplace_back(0.05f * i, 0.05f * j, height);
    }
  }
  AssessmentConfig config;
  config.num_threads = 1;
  return std::make_shared<PlanningMap>(TerrainModel::Assess(*cloud, config).value(),
                                       std::vector<Prism>{}, 0);
}

ServiceError::Code CodeOf(const ServiceStatus& status) {
  return status.ok() ? ServiceError::Code(ErrorCode::kInvalidInput) : status.error().code;
}

class PublishedMapsTest : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    if (!GetParam()) {
      published_ = std::make_unique<MemoryMaps>();
      return;
    }
    static int next = 0;
    root_ = fs::temp_directory_path() / ("strata_published_maps_test_" +
                                         std::to_string(::getpid()) + "_" + std::to_string(next++));
    fs::remove_all(root_);
    published_ = std::make_unique<StoredMaps>(Options());
  }
  // A store's maps over root_, sharing the metadata the fixture keeps.
  StoredMapsOptions Options() {
    StoredMapsOptions options;
    options.store = std::move(MapStore::Open(root_).value());  // Each its own, as replicas.
    options.encode_metadata = [this](const MapSnapshot& map) {
      std::lock_guard lock(mutex_);
      const std::string key = "m" + std::to_string(metadata_.size());
      metadata_[key] = map;
      return key;
    };
    options.decode_metadata = [this](const std::string& key) -> Result<MapSnapshot> {
      std::lock_guard lock(mutex_);
      return metadata_.at(key);
    };
    options.make_planning = [](std::shared_ptr<const TerrainModel> model,
                               std::vector<Prism> keep_out, const std::string&,
                               const std::string&) {
      return std::make_shared<PlanningMap>(std::move(model), std::move(keep_out), 0);
    };
    return options;
  }
  void TearDown() override {
    published_.reset();
    if (!root_.empty()) fs::remove_all(root_);
  }

  // Publishes map `id` at `version` (a floor `height` m up, `rows` samples long: FloorAt).
  ServiceStatus Publish(const std::string& id, const std::string& version, float height,
                        int rows = 60) {
    MapSnapshot map;
    map.id = id;
    map.state = MapState::kActive;
    map.version = version;
    map.versions = {version};
    PointCloud cloud;
    const auto planning = FloorAt(height, &cloud, rows);
    return published_->PublishNew(map, planning, cloud);
  }

  fs::path root_;
  std::mutex mutex_;
  std::map<std::string, MapSnapshot> metadata_;
  std::unique_ptr<PublishedMaps> published_;
};

const std::string kV1(32, 'a');
const std::string kV2(32, 'b');

TEST_P(PublishedMapsTest, AnswersForWhatItPublished) {
  ASSERT_TRUE(Publish("floor", kV1, 0).ok());
  EXPECT_THAT(published_->Versions("floor").value(), ElementsAre(kV1));
  const ActiveMap current = published_->Get("floor", "").value();
  EXPECT_EQ(current.version, kV1);
  EXPECT_EQ(published_->Get("floor", kV1).value().map, current.map);
  const Result<ActiveMap> other = published_->Get("floor", kV2);
  ASSERT_FALSE(other.ok());
  EXPECT_EQ(other.error().code, ServiceError::Code(ServiceErrorCode::kMapVersionNotFound));
  EXPECT_THAT(other.error().message, HasSubstr(kV1));
  const MapSnapshot described = published_->Describe("floor").value();
  EXPECT_EQ(described.version, kV1);
  EXPECT_EQ(described.state, MapState::kActive);
  EXPECT_GT(described.memory_bytes, 0u);
  EXPECT_EQ(published_->HeldCount(), 1);
  EXPECT_GT(published_->HeldBytes(), 0u);
  EXPECT_EQ(published_->PinnedCount(), GetParam() ? 0 : 1);

  ASSERT_TRUE(Publish("ramp", kV2, 1).ok());
  std::vector<std::string> listed;
  for (const MapSnapshot& map : published_->List("", 10)) listed.push_back(map.id);
  EXPECT_THAT(listed, ElementsAre("floor", "ramp"));
  ASSERT_EQ(published_->List("floor", 10).size(), 1u);
  EXPECT_EQ(published_->List("", 1).size(), 1u);
}

TEST_P(PublishedMapsTest, AnIdIsPublishedOnceAndDeletedOnce) {
  ASSERT_TRUE(Publish("floor", kV1, 0).ok());
  EXPECT_TRUE(Publish("floor", kV1, 0).ok());  // The same map made twice: one map.
  EXPECT_EQ(CodeOf(Publish("floor", kV2, 1)),
            ServiceError::Code(ServiceErrorCode::kMapAlreadyExists));
  ASSERT_TRUE(published_->Delete("floor").ok());
  EXPECT_EQ(CodeOf(published_->Delete("floor")),
            ServiceError::Code(ServiceErrorCode::kMapNotFound));
  const Result<std::vector<std::string>> gone = published_->Versions("floor");
  ASSERT_FALSE(gone.ok());
  EXPECT_EQ(gone.error().code, ServiceError::Code(ServiceErrorCode::kMapNotFound));
  EXPECT_FALSE(published_->Get("floor", "").ok());
  EXPECT_FALSE(published_->Describe("floor").ok());
}

TEST_P(PublishedMapsTest, OnlyAStoreKeepsWhatEditsNeed) {
  ASSERT_TRUE(Publish("floor", kV1, 0).ok());
  EXPECT_EQ(published_->KeepsClouds(), GetParam());
  MapSnapshot next = published_->Describe("floor").value();
  next.version = kV2;
  next.versions = {kV2, kV1};
  PointCloud cloud;
  std::shared_ptr<const PlanningMap> planning = FloorAt(0.5f, &cloud);
  const CutTerrain tiles = CutIntoTiles(planning->model(), cloud);
  const ServiceStatus edited = published_->PublishEdit(kV1, next, kV2, planning, &tiles, nullptr);
  if (!GetParam()) {
    EXPECT_EQ(CodeOf(edited), ServiceError::Code(ServiceErrorCode::kMapStoreRequired));
    EXPECT_EQ(CodeOf(published_->OpenFiles("floor", kV1).error()),
              ServiceError::Code(ServiceErrorCode::kMapStoreRequired));
    return;
  }
  ASSERT_TRUE(edited.ok()) << edited.error().message;
  EXPECT_THAT(published_->Versions("floor").value(), ElementsAre(kV2, kV1));
  EXPECT_EQ(published_->Get("floor", "").value().map, planning);
  // A second edit of the old base loses the compare-and-swap.
  MapSnapshot stale = next;
  stale.version = std::string(32, 'c');
  EXPECT_EQ(CodeOf(published_->PublishEdit(kV1, stale, stale.version, planning, &tiles, nullptr)),
            ServiceError::Code(ServiceErrorCode::kMapChanged));
  // The files an edit reads, and the cloud.
  const VersionFiles files = published_->OpenFiles("floor", kV2).value();
  ASSERT_TRUE(files.tiles.has_value());  // A terrain of the store's tiles.
  EXPECT_GE(files.tiles->dir->fd(), 0);
  EXPECT_EQ(files.tiles->list.cloud.size(), files.tiles->list.model.size());
  EXPECT_EQ(published_->LoadCloud("floor", kV2).value().size(), cloud.size());
  // A version no plan holds is let go, and loaded again on demand.
  planning.reset();
  published_->TrimTo(0);
  EXPECT_EQ(published_->HeldCount(), 0);
  EXPECT_EQ(published_->Get("floor", kV1).value().map->model().summary().input_points,
            cloud.size());

  // Keep-out zones alone: a version naming the base's terrain, with no cloud passed on.
  EXPECT_EQ(published_->TerrainOf("floor", kV2).value(), kV2);
  MapSnapshot zoned = published_->Describe("floor").value();
  zoned.version = std::string(32, 'd');
  zoned.keep_out = {Prism{{{0, 0}, {1, 0}, {1, 1}}, 0, 1}};
  const std::shared_ptr<const PlanningMap> base = published_->Get("floor", kV2).value().map;
  ASSERT_TRUE(
      published_->PublishEdit(kV2, zoned, kV2, base->WithKeepOut(zoned.keep_out), nullptr, nullptr)
          .ok());
  EXPECT_EQ(published_->TerrainOf("floor", zoned.version).value(), kV2);
  EXPECT_EQ(published_->LoadCloud("floor", zoned.version).value().size(), cloud.size());
  published_->TrimTo(0);
  const ActiveMap reloaded = published_->Get("floor", zoned.version).value();
  EXPECT_EQ(reloaded.map->keep_out().size(), 1u);
  EXPECT_EQ(reloaded.map->model().summary().input_points, cloud.size());

  // Another replica's zones on a terrain this one holds: the new version is the held map with
  // the zones (its model and graphs shared), not a second load of the same model.
  ASSERT_TRUE(reloaded.map->Graph(TraversabilityParams{}).ok());
  StoredMaps elsewhere(Options());
  MapSnapshot rezoned = published_->Describe("floor").value();
  rezoned.version = std::string(32, 'e');
  rezoned.keep_out.clear();
  const std::shared_ptr<const PlanningMap> theirs = elsewhere.Get("floor", "").value().map;
  ASSERT_TRUE(
      elsewhere.PublishEdit(zoned.version, rezoned, kV2, theirs->WithKeepOut({}), nullptr, nullptr)
          .ok());
  const ActiveMap seen_here = published_->Get("floor", "").value();
  EXPECT_EQ(seen_here.version, rezoned.version);
  EXPECT_TRUE(seen_here.map->keep_out().empty());
  EXPECT_EQ(seen_here.map->model_ptr(), reloaded.map->model_ptr());
  EXPECT_EQ(seen_here.map->GraphCount(), 1u);
}

// A replica following another's edits loads each head it plans on. It holds that one, not
// every version it ever loaded (which, without a memory budget, it would hold for ever); a
// plan on an older version finishes on it, and a request naming one loads it again.
TEST_P(PublishedMapsTest, AReplicaFollowingEditsHoldsTheHeadItLoaded) {
  if (!GetParam()) GTEST_SKIP() << "only a store's maps have versions made elsewhere";
  ASSERT_TRUE(Publish("floor", kV1, 0).ok());
  StoredMaps follower(Options());
  const ActiveMap first = follower.Get("floor", "").value();
  EXPECT_EQ(first.version, kV1);
  const std::string versions[] = {kV2, std::string(32, 'c'), std::string(32, 'd')};
  std::string base = kV1;
  for (const std::string& version : versions) {
    MapSnapshot next = published_->Describe("floor").value();
    next.version = version;
    PointCloud cloud;
    const std::shared_ptr<const PlanningMap> planning = FloorAt(0.5f, &cloud);
    const CutTerrain tiles = CutIntoTiles(planning->model(), cloud);
    ASSERT_TRUE(published_->PublishEdit(base, next, version, planning, &tiles, nullptr).ok());
    base = version;
    EXPECT_EQ(follower.Get("floor", "").value().version, version);
    EXPECT_EQ(follower.HeldCount(), 1) << "after " << version;
    EXPECT_NE(follower.Held("floor", version), nullptr);
  }
  EXPECT_EQ(follower.Held("floor", kV1), nullptr);
  EXPECT_EQ(first.map->model().summary().input_points, 3600u);  // The plan's copy lives.
  // A version asked for by name is loaded and held beside the head.
  EXPECT_EQ(follower.Get("floor", kV2).value().version, kV2);
  EXPECT_EQ(follower.HeldCount(), 2);
}

// A replica that planned on a version, loading the next one another replica made, patches its
// robots' graphs from the version it holds before any plan asks (the store may not hold them
// yet: the other replica writes them after publishing), and they are the new model's.
TEST_P(PublishedMapsTest, AReplicaLoadingTheNextVersionHasItsRobotsGraphsMadeAhead) {
  if (!GetParam()) GTEST_SKIP() << "only a store's maps have versions made elsewhere";
  ASSERT_TRUE(Publish("floor", kV1, 0).ok());
  StoredMaps follower(Options());
  const TraversabilityParams params = RobotProfile{}.Traversability();
  const ActiveMap first = follower.Get("floor", "").value();
  ASSERT_TRUE(first.map->Graph(params).ok());

  PointCloud cloud;  // The floor, with a gap that splits it in two.
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) {
      if (i < 28 || i > 32) cloud.emplace_back(0.05f * i, 0.05f * j, 0.0f);
    }
  }
  const auto split = std::make_shared<PlanningMap>(
      TerrainModel::Assess(cloud, first.map->model().config()).value(), std::vector<Prism>{}, 0);
  ASSERT_EQ(split->model().grid().size, first.map->model().grid().size);
  MapSnapshot next = published_->Describe("floor").value();
  next.version = kV2;
  const CutTerrain tiles = CutIntoTiles(split->model(), cloud);
  ASSERT_TRUE(published_->PublishEdit(kV1, next, kV2, split, &tiles, nullptr).ok());

  const ActiveMap loaded = follower.Get("floor", "").value();
  ASSERT_EQ(loaded.version, kV2);
  EXPECT_THAT(loaded.map->BuiltGraphParams(), ElementsAre(params));
  EXPECT_EQ(loaded.map->Graph(params).value()->component_count(), 2);
}

// A replica following another's edits loads each version beside the one it holds, sharing the
// chunks an edit left alone: the memory it keeps free for its next load is what this one added,
// not the whole map (a 1 km site: 0.8 of 2.7 GB).
TEST_P(PublishedMapsTest, AReplicaFollowingEditsKeepsRoomForWhatALoadAddsNotTheWholeMap) {
  if (!GetParam()) GTEST_SKIP() << "only a store's maps are loaded";
  // A floor 3 m x 16 m: two chunks of grid rows, of which the edit below (a hole) changes the
  // first.
  constexpr int kRows = 320;
  ASSERT_TRUE(Publish("floor", kV1, 0, kRows).ok());

  FreeMemoryReturner returner;
  FreeMemoryReturner::Room room(returner);
  StoredMapsOptions options = Options();
  options.free_memory = &room;
  StoredMaps follower(std::move(options));
  const ActiveMap first = follower.Get("floor", "").value();
  EXPECT_EQ(returner.RoomBytes(), first.map->MemoryBytes());  // Nothing held to share with.

  MapSnapshot next = published_->Describe("floor").value();
  next.version = kV2;
  PointCloud holed;
  const std::shared_ptr<const PlanningMap> edited = FloorAt(0, &holed, kRows, /*hole=*/true);
  const CutTerrain tiles = CutIntoTiles(edited->model(), holed);
  ASSERT_TRUE(published_->PublishEdit(kV1, next, kV2, edited, &tiles, nullptr).ok());
  const ActiveMap second = follower.Get("floor", "").value();
  ASSERT_EQ(second.version, kV2);
  const std::size_t added = second.map->MemoryBytesBeyond(first.map.get());
  EXPECT_GT(added, 0u);
  EXPECT_LT(added, second.map->MemoryBytes());  // The second chunk shared.
  EXPECT_EQ(returner.RoomBytes(), added);
}

INSTANTIATE_TEST_SUITE_P(MemoryAndStore, PublishedMapsTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? "StoredMaps" : "MemoryMaps";
                         });

}  // namespace
}  // namespace strata::server
