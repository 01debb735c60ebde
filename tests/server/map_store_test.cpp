#include "maps/map_store.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <iterator>
#include <latch>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "maps/store_files.hpp"
#include "maps/stored_graphs.hpp"
#include "maps/stored_tiles.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_graph.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/planner.hpp"
#include "strata/prism.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/paper_scenes.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

template <typename T>
bool Fails(const T& result, ServiceErrorCode code) {
  return !result.ok() && result.error().code == ServiceError::Code(code);
}
template <typename T>
bool Fails(const T& result, ErrorCode code) {
  return !result.ok() && result.error().code == ServiceError::Code(code);
}
template <typename T>
std::string Why(const T& result) {
  return result.ok() ? std::string("ok") : result.error().message;
}

// Every file and directory under `dir`, and `dir` itself, made older than the stale age.
void MakeStale(const fs::path& dir) {
  const auto old = fs::file_time_type::clock::now() - 2 * kStaleTemporaryAge;
  if (fs::is_directory(dir)) {
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
      fs::last_write_time(entry.path(), old);
    }
  }
  fs::last_write_time(dir, old);
}

class MapStoreTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A small model, assessed once: the store does not care what the model is of.
    config_ = new AssessmentConfig();
    config_->grid.resolution_m = 0.25;
    cloud_ = new PointCloud(GenerateTwoLevelRamp(2, 0.2));
    auto model = TerrainModel::Assess(*cloud_, *config_);
    ASSERT_TRUE(model.ok()) << model.error().message;
    model_ = new std::shared_ptr<const TerrainModel>(*model);
  }
  static void TearDownTestSuite() {
    delete config_;
    delete cloud_;
    delete model_;
  }

  void SetUp() override {
    std::random_device seed;
    root_ = fs::path(::testing::TempDir()) /
            ("map_store_test." + std::to_string(::getpid()) + "." + std::to_string(seed()));
    auto store = MapStore::Open(root_);
    ASSERT_TRUE(store.ok()) << store.error().message;
    store_ = std::move(*store);
  }
  void TearDown() override {
    store_.reset();
    std::error_code ignored;
    fs::remove_all(root_, ignored);
  }

  static const PointCloud& cloud() { return *cloud_; }
  static const AssessmentConfig& config() { return *config_; }
  static const TerrainModel& model() { return **model_; }

  // The cloud with point 0 moved by `shift_m` in x: other content, another version.
  static PointCloud Variant(int shift) {
    PointCloud variant = cloud();
    variant[0].x() += 0.001f * static_cast<float>(shift);
    return variant;
  }
  static std::string VersionOf(const PointCloud& points) {
    return MapStore::VersionOf(points, config(), {});
  }

  // Puts the terrain of `points` (with the shared model) and its version without zones.
  static ServiceStatus PutBoth(MapStore& store, const std::string& id, const std::string& version,
                               const PointCloud& points, const std::string& metadata) {
    ServiceStatus put = store.PutTerrain(id, version, CutIntoTiles(model(), points));
    if (put.ok()) put = store.PutVersion(id, version, version, metadata);
    return put;
  }
  // Puts the version of `points` and returns its name.
  std::string Put(MapStore& store, const std::string& id, const PointCloud& points,
                  const std::string& metadata = "{}") {
    const std::string version = VersionOf(points);
    const ServiceStatus put = PutBoth(store, id, version, points, metadata);
    EXPECT_TRUE(put.ok()) << Why(put);
    return version;
  }
  std::string Create(const std::string& id, const PointCloud& points) {
    const std::string version = Put(*store_, id, points);
    const ServiceStatus published = store_->PublishNew(id, version);
    EXPECT_TRUE(published.ok()) << Why(published);
    return version;
  }

  // The points in lexicographic order: a cloud comes back from the store tile by tile.
  static PointCloud Sorted(PointCloud points) {
    std::sort(points.begin(), points.end(), [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
      return std::tuple(a.x(), a.y(), a.z()) < std::tuple(b.x(), b.y(), b.z());
    });
    return points;
  }

  // The names of the tiles the terrains of map `id` list.
  std::set<std::string> ListedTiles(const std::string& id) const {
    std::set<std::string> names;
    for (const fs::path& terrain : Entries(root_ / "maps" / id / "terrains")) {
      std::ifstream file(terrain / "tiles");
      const std::string text{std::istreambuf_iterator<char>(file), {}};
      const auto list = TerrainTiles::Parse(text, terrain / "tiles");
      EXPECT_TRUE(list.ok()) << Why(list);
      if (!list.ok()) continue;
      for (const std::string& name : list->Names()) names.insert(name);
    }
    return names;
  }
  // The names of the tiles in map `id`'s tiles/.
  std::set<std::string> StoredTiles(const std::string& id) const {
    std::set<std::string> names;
    for (const fs::path& tile : Entries(root_ / "maps" / id / "tiles")) {
      names.insert(tile.filename().string());
    }
    return names;
  }

  // 4 M points over 100 × 100 m: stored with the small shared model, whose grid is 2 tiles,
  // they are two cloud tiles of 24 MB, each taking a good fraction of a second to write.
  static PointCloud BigCloud() {
    PointCloud big;
    constexpr int kSide = 2000;
    big.reserve(kSide * kSide);
    for (int i = 0; i < kSide; ++i) {
      for (int j = 0; j < kSide; ++j) big.emplace_back(0.05f * i, 0.05f * j, 0.001f * (i % 7));
    }
    return big;
  }

  // The sizes of the tiles PutBoth writes for `points` on a store that holds no tile of
  // theirs, in the order it writes them.
  static std::vector<std::size_t> TileSizes(const PointCloud& points) {
    std::vector<std::size_t> sizes;
    for (const auto& tile : CutIntoTiles(model(), points).tiles)
      sizes.push_back(tile.second.size());
    return sizes;
  }

  // Forks a writer that opens the store at root_ and runs `write` on it, with its files limited
  // to `file_limit` bytes: the kernel kills it (SIGXFSZ) in the middle of the first write that
  // would grow a file past the limit, a crash mid-write at a point the test chose. Returns its
  // pid (negative when fork failed).
  pid_t ForkWriterDyingPast(std::size_t file_limit,
                            const std::function<bool(MapStore&)>& write) const {
    const pid_t pid = ::fork();
    if (pid == 0) {
      const rlimit no_core{0, 0};
      const rlimit limit{file_limit, file_limit};
      ::signal(SIGXFSZ, SIG_DFL);  // Killed, whatever the parent's disposition.
      if (::setrlimit(RLIMIT_CORE, &no_core) != 0 || ::setrlimit(RLIMIT_FSIZE, &limit) != 0) {
        ::_exit(2);
      }
      auto store = MapStore::Open(root_);
      ::_exit(store.ok() && write(**store) ? 0 : 1);
    }
    return pid;
  }

  // Waits for the writer `pid` and fails the test unless the file limit killed it.
  static void ExpectKilledMidWrite(pid_t pid) {
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer was not killed; it exited with "
                                     << (WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    ASSERT_EQ(WTERMSIG(status), SIGXFSZ);
  }

  // The entries of `dir` whose names start with `prefix`.
  static std::vector<fs::path> Entries(const fs::path& dir, std::string_view prefix = "") {
    std::vector<fs::path> entries;
    if (fs::exists(dir)) {
      for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
        if (e.path().filename().string().starts_with(prefix)) entries.push_back(e.path());
      }
    }
    return entries;
  }

  fs::path root_;
  std::unique_ptr<MapStore> store_;

 private:
  static AssessmentConfig* config_;
  static PointCloud* cloud_;
  static std::shared_ptr<const TerrainModel>* model_;
};

AssessmentConfig* MapStoreTest::config_ = nullptr;
PointCloud* MapStoreTest::cloud_ = nullptr;
std::shared_ptr<const TerrainModel>* MapStoreTest::model_ = nullptr;

TEST_F(MapStoreTest, RoundTrip) {
  const std::string metadata("{\"id\": \"ramp\"}\n\0binary", 23);
  const std::string version = Put(*store_, "ramp", cloud(), metadata);
  ASSERT_TRUE(store_->PublishNew("ramp", version).ok());

  auto versions = store_->Versions("ramp");
  ASSERT_TRUE(versions.ok()) << Why(versions);
  EXPECT_THAT(*versions, ElementsAre(version));
  auto current = store_->Current("ramp");
  ASSERT_TRUE(current.ok()) << Why(current);
  EXPECT_EQ(*current, version);

  auto loaded_model = store_->LoadModel("ramp", version);
  ASSERT_TRUE(loaded_model.ok()) << Why(loaded_model);
  EXPECT_EQ(SerializeModel(**loaded_model), SerializeModel(model()));
  auto loaded_cloud = store_->LoadCloud("ramp", version);
  ASSERT_TRUE(loaded_cloud.ok()) << Why(loaded_cloud);
  EXPECT_EQ(Sorted(*loaded_cloud), Sorted(cloud()));  // In the order of its tiles.
  auto loaded_metadata = store_->LoadMetadata("ramp", version);
  ASSERT_TRUE(loaded_metadata.ok()) << Why(loaded_metadata);
  EXPECT_EQ(*loaded_metadata, metadata);

  // Another store on the same directory (another server) sees the same.
  auto other = MapStore::Open(root_);
  ASSERT_TRUE(other.ok()) << Why(other);
  auto ids = (*other)->ListIds("", 0);
  ASSERT_TRUE(ids.ok()) << Why(ids);
  EXPECT_THAT(*ids, ElementsAre("ramp"));
  auto other_metadata = (*other)->LoadMetadata("ramp", version);
  ASSERT_TRUE(other_metadata.ok());
  EXPECT_EQ(*other_metadata, metadata);
}

TEST_F(MapStoreTest, VersionNamesTheContent) {
  const std::string version = VersionOf(cloud());
  EXPECT_TRUE(MapStore::IsVersion(version)) << version;
  EXPECT_EQ(version.size(), 32u);
  EXPECT_EQ(VersionOf(PointCloud(cloud())), version);

  // One point, by one float step; two points swapped.
  PointCloud nudged = cloud();
  nudged[nudged.size() / 2].z() = std::nextafter(nudged[nudged.size() / 2].z(), 1e9f);
  EXPECT_NE(VersionOf(nudged), version);
  PointCloud swapped = cloud();
  std::swap(swapped[1], swapped[2]);
  EXPECT_NE(VersionOf(swapped), version);
  PointCloud shorter(cloud().begin(), cloud().end() - 1);
  EXPECT_NE(VersionOf(shorter), version);

  // Every assessment parameter but num_threads, each changed alone.
  int changed = 0;
  const AssessmentConfig fields;
  ForEachField(fields, [&](const char* name, const auto& /*value*/) {
    AssessmentConfig other = config();
    int index = 0;
    ForEachField(other, [&](const char* field, auto& value) {
      if (index++ == changed) {
        using Value = std::remove_cvref_t<decltype(value)>;
        if constexpr (std::is_same_v<Value, bool>) {
          value = !value;
        } else {
          value = static_cast<Value>(value + 1);
        }
        EXPECT_STREQ(field, name);
      }
    });
    const std::string other_version = MapStore::VersionOf(cloud(), other, {});
    if (std::string_view(name) == "num_threads") {
      EXPECT_EQ(other_version, version) << name;
    } else {
      EXPECT_NE(other_version, version) << name;
    }
    ++changed;
  });
  EXPECT_GT(changed, 10);

  // Keep-out zones: one added, one corner moved, the height range changed.
  const Prism zone =
      BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(2, 2, 1)));
  const std::vector<Prism> zones = {zone};
  const std::string with_zone = MapStore::VersionOf(cloud(), config(), zones);
  EXPECT_NE(with_zone, version);
  EXPECT_EQ(MapStore::VersionOf(cloud(), config(), std::vector<Prism>{zone}), with_zone);
  Prism moved = zone;
  moved.polygon_m[2].x() += 0.01;
  EXPECT_NE(MapStore::VersionOf(cloud(), config(), std::vector<Prism>{moved}), with_zone);
  Prism taller = zone;
  taller.z_max_m += 0.01;
  EXPECT_NE(MapStore::VersionOf(cloud(), config(), std::vector<Prism>{taller}), with_zone);
  EXPECT_NE(MapStore::VersionOf(cloud(), config(), std::vector<Prism>{zone, zone}), with_zone);
}

TEST_F(MapStoreTest, ManyWritersCreatingTheSameMapYieldOneVersion) {
  auto other = MapStore::Open(root_);
  ASSERT_TRUE(other.ok());
  MapStore* stores[] = {store_.get(), other->get()};
  constexpr int kWriters = 8;
  std::latch start(kWriters);
  std::vector<ServiceStatus> results(kWriters);
  std::vector<std::thread> writers;
  for (int i = 0; i < kWriters; ++i) {
    writers.emplace_back([&, i] {
      MapStore& store = *stores[i % 2];
      const std::string version = VersionOf(cloud());
      start.arrive_and_wait();
      results[i] = PutBoth(store, "same", version, cloud(), "{}");
      if (results[i].ok()) results[i] = store.PublishNew("same", version);
    });
  }
  for (std::thread& writer : writers) writer.join();
  for (const ServiceStatus& result : results) EXPECT_TRUE(result.ok()) << Why(result);
  auto versions = store_->Versions("same");
  ASSERT_TRUE(versions.ok());
  EXPECT_THAT(*versions, ElementsAre(VersionOf(cloud())));
  EXPECT_EQ(Entries(root_ / "maps" / "same" / "versions").size(), 1u);
  EXPECT_THAT(Entries(root_ / "tmp"), IsEmpty());
}

TEST_F(MapStoreTest, ManyWritersCreatingDifferentMapsUnderOneIdHaveOneWinner) {
  auto other = MapStore::Open(root_);
  ASSERT_TRUE(other.ok());
  MapStore* stores[] = {store_.get(), other->get()};
  constexpr int kWriters = 8;
  std::vector<std::string> versions(kWriters);
  for (int i = 0; i < kWriters; ++i) versions[i] = Put(*stores[i % 2], "contested", Variant(i));
  std::latch start(kWriters);
  std::vector<ServiceStatus> results(kWriters);
  std::vector<std::thread> writers;
  for (int i = 0; i < kWriters; ++i) {
    writers.emplace_back([&, i] {
      start.arrive_and_wait();
      results[i] = stores[i % 2]->PublishNew("contested", versions[i]);
    });
  }
  for (std::thread& writer : writers) writer.join();
  int winner = -1;
  for (int i = 0; i < kWriters; ++i) {
    if (results[i].ok()) {
      EXPECT_EQ(winner, -1) << "two winners";
      winner = i;
    } else {
      EXPECT_TRUE(Fails(results[i], ServiceErrorCode::kMapAlreadyExists)) << Why(results[i]);
    }
  }
  ASSERT_NE(winner, -1);
  auto current = store_->Current("contested");
  ASSERT_TRUE(current.ok());
  EXPECT_EQ(*current, versions[winner]);
}

TEST_F(MapStoreTest, ProcessesCreatingDifferentMapsUnderOneIdHaveOneWinner) {
  // Separate processes: only the file lock keeps them apart.
  constexpr int kWriters = 4;
  std::vector<std::string> versions(kWriters);
  for (int i = 0; i < kWriters; ++i) versions[i] = Put(*store_, "contested", Variant(i));
  const fs::path go = root_ / "go";
  std::vector<pid_t> children;
  for (int i = 0; i < kWriters; ++i) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      auto store = MapStore::Open(root_);
      if (!store.ok()) ::_exit(3);
      while (!fs::exists(go)) std::this_thread::yield();
      const ServiceStatus published = (*store)->PublishNew("contested", versions[i]);
      ::_exit(published.ok() ? 0 : Fails(published, ServiceErrorCode::kMapAlreadyExists) ? 1 : 2);
    }
    children.push_back(pid);
  }
  std::ofstream(go) << "go";
  std::multiset<int> exits;
  for (const pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status));
    exits.insert(WEXITSTATUS(status));
  }
  EXPECT_EQ(exits.count(0), 1u);
  EXPECT_EQ(exits.count(1), kWriters - 1u);
}

TEST_F(MapStoreTest, PublishUpdateIsACompareAndSwap) {
  const std::string v1 = Create("edited", Variant(1));
  const std::string v2 = Put(*store_, "edited", Variant(2));
  const std::string v3 = Put(*store_, "edited", Variant(3));
  ASSERT_TRUE(store_->PublishUpdate("edited", v1, v2, 5).ok());

  // A writer that read v1 before that update lost.
  const ServiceStatus stale = store_->PublishUpdate("edited", v1, v3, 5);
  EXPECT_TRUE(Fails(stale, ServiceErrorCode::kMapChanged)) << Why(stale);
  EXPECT_THAT(Why(stale), HasSubstr(v2));
  EXPECT_EQ(*store_->Current("edited"), v2);

  // The same edit made twice (two replicas): one version, no error.
  EXPECT_TRUE(store_->PublishUpdate("edited", v1, v2, 5).ok());
  EXPECT_THAT(*store_->Versions("edited"), ElementsAre(v2, v1));

  // A version never put is refused, and nothing changes.
  const std::string never = VersionOf(Variant(99));
  EXPECT_TRUE(
      Fails(store_->PublishUpdate("edited", v2, never, 5), ServiceErrorCode::kMapVersionNotFound));
  EXPECT_TRUE(Fails(store_->PublishUpdate("absent", v2, v3, 5), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->PublishUpdate("edited", v2, v3, 0), ErrorCode::kInvalidInput));
  EXPECT_THAT(*store_->Versions("edited"), ElementsAre(v2, v1));

  // Concurrent edits of the current version: one wins, the others are told.
  constexpr int kWriters = 6;
  std::vector<std::string> edits(kWriters);
  for (int i = 0; i < kWriters; ++i) edits[i] = Put(*store_, "edited", Variant(10 + i));
  auto other = MapStore::Open(root_);
  ASSERT_TRUE(other.ok());
  MapStore* stores[] = {store_.get(), other->get()};
  std::latch start(kWriters);
  std::vector<ServiceStatus> results(kWriters);
  std::vector<std::thread> writers;
  for (int i = 0; i < kWriters; ++i) {
    writers.emplace_back([&, i] {
      start.arrive_and_wait();
      results[i] = stores[i % 2]->PublishUpdate("edited", v2, edits[i], 5);
    });
  }
  for (std::thread& writer : writers) writer.join();
  int wins = 0;
  for (int i = 0; i < kWriters; ++i) {
    if (results[i].ok()) {
      ++wins;
      EXPECT_EQ(*store_->Current("edited"), edits[i]);
    } else {
      EXPECT_TRUE(Fails(results[i], ServiceErrorCode::kMapChanged)) << Why(results[i]);
    }
  }
  EXPECT_EQ(wins, 1);
  // A lost race leaves nothing behind: every version directory left is one the head lists.
  const std::vector<std::string> listed = *store_->Versions("edited");
  std::set<std::string> on_disk;
  for (const auto& entry : fs::directory_iterator(root_ / "maps" / "edited" / "versions")) {
    on_disk.insert(entry.path().filename().string());
  }
  EXPECT_EQ(on_disk, std::set<std::string>(listed.begin(), listed.end()));
}

TEST_F(MapStoreTest, PruningKeepsTheNewestVersions) {
  constexpr int kKeep = 3;
  std::vector<std::string> versions = {Create("pruned", Variant(0))};
  for (int i = 1; i <= 5; ++i) {
    versions.push_back(Put(*store_, "pruned", Variant(i)));
    ASSERT_TRUE(store_->PublishUpdate("pruned", versions[i - 1], versions[i], kKeep).ok());
  }
  EXPECT_THAT(*store_->Versions("pruned"), ElementsAre(versions[5], versions[4], versions[3]));
  EXPECT_EQ(Entries(root_ / "maps" / "pruned" / "versions").size(),
            static_cast<std::size_t>(kKeep));
  for (int i = 3; i <= 5; ++i) EXPECT_TRUE(store_->LoadMetadata("pruned", versions[i]).ok());

  const auto gone = store_->LoadModel("pruned", versions[1]);
  ASSERT_TRUE(Fails(gone, ServiceErrorCode::kMapVersionNotFound)) << Why(gone);
  EXPECT_THAT(gone.error().message, HasSubstr("pruned"));
  EXPECT_THAT(gone.error().message, HasSubstr(versions[1]));
  EXPECT_THAT(gone.error().message, HasSubstr(versions[5]));
  EXPECT_TRUE(
      Fails(store_->LoadCloud("pruned", versions[0]), ServiceErrorCode::kMapVersionNotFound));
}

// A keep-out zone changes no terrain: its version is two small files naming its parent's.
TEST_F(MapStoreTest, AVersionOfZonesAloneSharesItsTerrain) {
  const std::string base = Create("zoned", cloud());
  EXPECT_EQ(*store_->TerrainOfVersion("zoned", base), base);  // A first version names it so.
  const Prism zone{{{0, 0}, {1, 0}, {1, 1}}, 0, 2};
  const std::string zoned = MapStore::VersionOf(base, std::vector<Prism>{zone});
  EXPECT_NE(zoned, base);
  EXPECT_EQ(MapStore::VersionOf(cloud(), config(), std::vector<Prism>{zone}), zoned);
  ASSERT_TRUE(store_->HasTerrain("zoned", base));
  ASSERT_TRUE(store_->PutVersion("zoned", zoned, base, "{\"zones\":1}").ok());
  ASSERT_TRUE(store_->PublishUpdate("zoned", base, zoned, 1).ok());

  const fs::path map_dir = root_ / "maps" / "zoned";
  EXPECT_EQ(Entries(map_dir / "terrains").size(), 1u);
  std::set<std::string> files;
  for (const fs::path& file : Entries(map_dir / "versions" / zoned)) {
    files.insert(file.filename().string());
    EXPECT_LT(fs::file_size(file), 64u) << file;
  }
  EXPECT_EQ(files, (std::set<std::string>{"metadata", "terrain"}));
  // The base is pruned (one version kept); the terrain stays with the version naming it.
  EXPECT_THAT(*store_->Versions("zoned"), ElementsAre(zoned));
  EXPECT_EQ(store_->LoadCloud("zoned", zoned)->size(), cloud().size());
  EXPECT_EQ(SerializeModel(**store_->LoadModel("zoned", zoned)), SerializeModel(model()));

  // Once no version names it, it goes with the last one.
  const std::string next = Put(*store_, "zoned", Variant(1));
  ASSERT_TRUE(store_->PublishUpdate("zoned", zoned, next, 1).ok());
  EXPECT_THAT(Entries(map_dir / "terrains"), ElementsAre(map_dir / "terrains" / next));
  EXPECT_FALSE(store_->HasTerrain("zoned", base));
  // A version whose terrain is gone is neither put nor published.
  EXPECT_TRUE(
      Fails(store_->PutVersion("zoned", zoned, base, "{}"), ServiceErrorCode::kMapVersionNotFound));
  fs::remove_all(map_dir / "terrains" / next);
  const std::string orphan = MapStore::VersionOf(next, std::vector<Prism>{zone});
  fs::create_directories(map_dir / "versions" / orphan);
  std::ofstream(map_dir / "versions" / orphan / "terrain") << next << "\n";
  EXPECT_TRUE(Fails(store_->PublishUpdate("zoned", next, orphan, 2),
                    ServiceErrorCode::kMapVersionNotFound));
}

// A store written by layout 1 (a version holds its cloud and model) is taken over and read.
TEST_F(MapStoreTest, ReadsAStoreOfLayout1) {
  const fs::path old_root = root_ / "layout1";
  const std::string version = VersionOf(cloud());
  const fs::path version_dir = old_root / "maps" / "old" / "versions" / version;
  fs::create_directories(version_dir);
  std::ofstream(old_root / "strata-map-store") << "strata map store, layout 1\n";
  std::ofstream(old_root / "maps" / "old" / "head") << version << "\n";
  std::ofstream(version_dir / "metadata") << "{}";
  ASSERT_TRUE(SavePcd(cloud(), (version_dir / "cloud.pcd").string()).ok());
  ASSERT_TRUE(SaveModel(model(), (version_dir / "model.stratamodel").string()).ok());

  auto opened = MapStore::Open(old_root);
  ASSERT_TRUE(opened.ok()) << Why(opened);
  MapStore& store = **opened;
  std::ifstream marker(old_root / "strata-map-store");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(marker), {}),
            "strata map store, layout 3\n");
  EXPECT_EQ(*store.TerrainOfVersion("old", version), "");
  EXPECT_EQ(store.LoadCloud("old", version)->size(), cloud().size());
  EXPECT_EQ(SerializeModel(**store.LoadModel("old", version)), SerializeModel(model()));
  // A later version of it is of layout 3, and pruning the old one removes it whole.
  const std::string next = Put(store, "old", Variant(1));
  ASSERT_TRUE(store.PublishUpdate("old", version, next, 1).ok());
  EXPECT_FALSE(fs::exists(version_dir));
  EXPECT_EQ(store.LoadCloud("old", next)->size(), cloud().size());
}

TEST_F(MapStoreTest, DeleteRemovesTheMapForEveryone) {
  const std::string version = Create("doomed", cloud());
  auto other = MapStore::Open(root_);
  ASSERT_TRUE(other.ok());
  ASSERT_TRUE((*other)->Delete("doomed").ok());

  EXPECT_TRUE(Fails(store_->Versions("doomed"), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->Current("doomed"), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->LoadModel("doomed", version), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->LoadCloud("doomed", version), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->LoadMetadata("doomed", version), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(
      Fails(store_->PublishUpdate("doomed", version, version, 2), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store_->Delete("doomed"), ServiceErrorCode::kMapNotFound));
  EXPECT_THAT(*store_->ListIds("", 0), IsEmpty());
  (*other)->WaitForRemovals();  // Gone for everyone at once, off the volume in the background.
  EXPECT_THAT(Entries(root_ / "trash"), IsEmpty());

  // The id is free again.
  EXPECT_TRUE(Fails(store_->PublishNew("doomed", version), ServiceErrorCode::kMapVersionNotFound));
  const std::string again = Create("doomed", Variant(1));
  EXPECT_THAT(*(*other)->Versions("doomed"), ElementsAre(again));
}

// Whether a thread waits for a flock on the file of inode `inode` (/proc/locks marks the locks
// waited for with "->").
bool WaitedFor(ino_t inode) {
  std::ifstream locks("/proc/locks");
  const std::string file = ":" + std::to_string(inode) + " ";
  for (std::string line; std::getline(locks, line);) {
    if (line.find("->") != std::string::npos && line.find(file) != std::string::npos) return true;
  }
  return false;
}

// Deletes map "doomed" through `remover` while `publisher` publishes `next` over `current` as
// map "m" of the store at `root`, its publish held inside its write by the map's lock (taken
// here as another process would), and checks that nothing is removed until the publish is
// done. (Waiting a second for what must not happen: a removal without the wait takes
// milliseconds.)
void ExpectRemovalWaitsForPublish(const fs::path& root, MapStore& remover, MapStore& publisher,
                                  const std::string& current, const std::string& next) {
  const auto in_trash = [&root] {
    return std::distance(fs::directory_iterator(root / "trash"), fs::directory_iterator());
  };
  const store_files::Fd held(::open((root / "maps" / "m" / "lock").c_str(), O_RDWR | O_CLOEXEC));
  ASSERT_TRUE(held.valid());
  ASSERT_EQ(::flock(held.get(), LOCK_EX), 0);
  auto publish = std::async(std::launch::async,
                            [&] { return publisher.PublishUpdate("m", current, next, 3); });
  struct stat lock_file {};
  ASSERT_EQ(::fstat(held.get(), &lock_file), 0);
  while (!WaitedFor(lock_file.st_ino)) {
    ASSERT_EQ(publish.wait_for(std::chrono::milliseconds(1)), std::future_status::timeout);
  }
  ASSERT_TRUE(remover.Delete("doomed").ok());
  auto removed = std::async(std::launch::async, [&] { remover.WaitForRemovals(); });
  EXPECT_EQ(removed.wait_for(std::chrono::seconds(1)), std::future_status::timeout);
  EXPECT_EQ(in_trash(), 1);
  ASSERT_EQ(::flock(held.get(), LOCK_UN), 0);
  EXPECT_TRUE(publish.get().ok());
  removed.get();
  EXPECT_EQ(in_trash(), 0);
}

TEST_F(MapStoreTest, TheRemoverWaitsWhileAVersionIsPublished) {
  // A removal beside a write made its fsyncs wait (a keep-out zone on a site: 20-60 ms).
  const std::string current = Create("m", cloud());
  const std::string next = Put(*store_, "m", Variant(1));
  Create("doomed", Variant(2));
  ExpectRemovalWaitsForPublish(root_, *store_, *store_, current, next);
}

// Replicas share a store: a write in one holds off the removers of the others. Two MapStore
// objects hold the `writing` file on descriptors of their own, as two processes do.
TEST_F(MapStoreTest, TheRemoverWaitsWhileAnotherProcessPublishes) {
  const std::string current = Create("m", cloud());
  const std::string next = Put(*store_, "m", Variant(1));
  Create("doomed", Variant(2));
  auto replica = MapStore::Open(root_);
  ASSERT_TRUE(replica.ok()) << replica.error().message;
  ExpectRemovalWaitsForPublish(root_, *store_, **replica, current, next);
}

TEST_F(MapStoreTest, ListsIdsInOrderFromACursor) {
  for (const char* id : {"b", "a", "c", "a.1"}) Create(id, cloud());
  Put(*store_, "unpublished", cloud());  // Put but never published: not a map.
  EXPECT_THAT(*store_->ListIds("", 0), ElementsAre("a", "a.1", "b", "c"));
  EXPECT_THAT(*store_->ListIds("a", 2), ElementsAre("a.1", "b"));
  EXPECT_THAT(*store_->ListIds("b", 10), ElementsAre("c"));
  EXPECT_THAT(*store_->ListIds("c", 10), IsEmpty());
  EXPECT_TRUE(Fails(store_->Versions("unpublished"), ServiceErrorCode::kMapNotFound));
}

TEST_F(MapStoreTest, RefusesNamesThatLeaveTheRoot) {
  const std::string version = VersionOf(cloud());
  for (const std::string& id : std::vector<std::string>{
           "", ".", "..", "a/b", "../x", std::string("a\0b", 3), std::string(65, 'a')}) {
    EXPECT_TRUE(Fails(PutBoth(*store_, id, version, cloud(), ""), ErrorCode::kInvalidInput)) << id;
    EXPECT_TRUE(Fails(store_->Versions(id), ErrorCode::kInvalidInput)) << id;
    EXPECT_TRUE(Fails(store_->Delete(id), ErrorCode::kInvalidInput)) << id;
  }
  for (const std::string& bad :
       std::vector<std::string>{"", "../../etc", version.substr(1), version + "0",
                                std::string(32, 'A'), std::string(32, 'g')}) {
    EXPECT_TRUE(Fails(PutBoth(*store_, "m", bad, cloud(), ""), ErrorCode::kInvalidInput)) << bad;
    EXPECT_TRUE(Fails(store_->LoadModel("m", bad), ErrorCode::kInvalidInput)) << bad;
  }
  EXPECT_THAT(Entries(root_ / "maps"), IsEmpty());
}

TEST_F(MapStoreTest, OpenRefusesWhatIsNoStore) {
  const fs::path file = root_ / "a-file";
  std::ofstream(file) << "x";
  auto on_file = MapStore::Open(file);
  ASSERT_TRUE(Fails(on_file, ErrorCode::kInvalidConfig));
  EXPECT_THAT(on_file.error().message, HasSubstr("--map-store"));
  EXPECT_TRUE(Fails(MapStore::Open(""), ErrorCode::kInvalidConfig));

  const fs::path other = root_ / "other";
  fs::create_directories(other);
  std::ofstream(other / "strata-map-store") << "strata map store, layout 99\n";
  EXPECT_TRUE(Fails(MapStore::Open(other), ErrorCode::kInvalidConfig));
}

TEST_F(MapStoreTest, AWriterKilledMidWriteLeavesNoVersion) {
  const PointCloud big = BigCloud();
  const std::string version = VersionOf(big);
  // Killed 1 MB into the first of the cloud's two big tiles (24 MB): the small tiles before
  // it are in tiles/, not listed by any terrain.
  constexpr std::size_t kLimit = std::size_t{1} << 20;
  const std::vector<std::size_t> sizes = TileSizes(big);
  ASSERT_GT(sizes.size(), 2u);
  ASSERT_LT(*std::max_element(sizes.begin(), sizes.end() - 2), kLimit);
  ASSERT_GT(sizes[sizes.size() - 2], kLimit);
  const pid_t pid = ForkWriterDyingPast(kLimit, [&](MapStore& store) {
    return PutBoth(store, "big", version, big, "{}").ok() && store.PublishNew("big", version).ok();
  });
  ASSERT_GE(pid, 0);
  ExpectKilledMidWrite(pid);
  const std::vector<fs::path> left = Entries(root_ / "tmp", "tile.");
  ASSERT_EQ(left.size(), 1u);  // Its half-written tile.
  EXPECT_EQ(fs::file_size(left.front()), kLimit);

  auto fresh = MapStore::Open(root_);
  ASSERT_TRUE(fresh.ok()) << Why(fresh);
  MapStore& store = **fresh;
  EXPECT_THAT(*store.ListIds("", 0), IsEmpty());
  EXPECT_TRUE(Fails(store.Versions("big"), ServiceErrorCode::kMapNotFound));
  EXPECT_TRUE(Fails(store.LoadModel("big", version), ServiceErrorCode::kMapNotFound));
  EXPECT_THAT(Entries(root_ / "maps" / "big" / "versions"), IsEmpty());
  EXPECT_THAT(Entries(root_ / "maps" / "big" / "terrains"), IsEmpty());

  ASSERT_TRUE(PutBoth(store, "big", version, big, "{}").ok());
  ASSERT_TRUE(store.PublishNew("big", version).ok());
  auto loaded = store.LoadCloud("big", version);
  ASSERT_TRUE(loaded.ok()) << Why(loaded);
  EXPECT_EQ(loaded->size(), big.size());

  // The dead writer's temporary is young, so it stays (it could be a live writer's) until
  // it is older than the stale age.
  ASSERT_EQ(Entries(root_ / "tmp").size(), 1u);
  EXPECT_EQ(store.CollectGarbage(), 0);
  MakeStale(Entries(root_ / "tmp", "tile.").front());
  EXPECT_EQ(store.CollectGarbage(), 1);
  EXPECT_THAT(Entries(root_ / "tmp"), IsEmpty());
}

// The kill test: a writer making a map's next version is killed in the middle of
// writing its tiles. The current version stays whole, nothing lists the tiles it left, and
// those are collected.
TEST_F(MapStoreTest, AWriterKilledMidTiledWriteLeavesTheCurrentVersionWhole) {
  const std::string current = Create("site", cloud());
  const std::set<std::string> current_tiles = StoredTiles("site");
  // Dense in its second cloud tile, sparse in its first: the writer is killed once the first
  // is in place, while it writes the second.
  PointCloud next_cloud;
  for (const Eigen::Vector3f& point : BigCloud()) {
    if (point.x() >= 50.0f || std::lround(point.y() / 0.05f) % 8 == 0) next_cloud.push_back(point);
  }
  const std::string next = VersionOf(next_cloud);
  const std::vector<std::size_t> sizes = TileSizes(next_cloud);
  ASSERT_GT(sizes.size(), 2u);
  const std::size_t first = sizes[sizes.size() - 2];
  const std::size_t last = sizes.back();
  ASSERT_LT(2 * first, last);
  const pid_t pid = ForkWriterDyingPast((first + last) / 2, [&](MapStore& store) {
    return PutBoth(store, "site", next, next_cloud, "{}").ok() &&
           store.PublishUpdate("site", current, next, 2).ok();
  });
  ASSERT_GE(pid, 0);
  ExpectKilledMidWrite(pid);
  ASSERT_GT(StoredTiles("site").size(), current_tiles.size());  // The first is in place.

  auto fresh = MapStore::Open(root_);  // Another replica, or this one restarted.
  ASSERT_TRUE(fresh.ok()) << Why(fresh);
  MapStore& store = **fresh;
  EXPECT_THAT(*store.Versions("site"), ElementsAre(current));
  const auto model_now = store.LoadModel("site", current);
  ASSERT_TRUE(model_now.ok()) << Why(model_now);
  EXPECT_EQ(SerializeModel(**model_now), SerializeModel(model()));
  const auto cloud_now = store.LoadCloud("site", current);
  ASSERT_TRUE(cloud_now.ok()) << Why(cloud_now);
  EXPECT_EQ(Sorted(*cloud_now), Sorted(cloud()));
  EXPECT_TRUE(Fails(store.LoadModel("site", next), ServiceErrorCode::kMapVersionNotFound));
  // Open collected the tiles no terrain lists: the dead writer's.
  EXPECT_EQ(StoredTiles("site"), current_tiles);

  // Made again, it lands.
  ASSERT_TRUE(PutBoth(store, "site", next, next_cloud, "{}").ok());
  ASSERT_TRUE(store.PublishUpdate("site", current, next, 2).ok());
  EXPECT_EQ(store.LoadCloud("site", next)->size(), next_cloud.size());
}

TEST_F(MapStoreTest, ATamperedVersionFailsToLoadClearly) {
  const std::string version = Create("tampered", cloud());
  const fs::path dir = root_ / "maps" / "tampered" / "terrains" / version;
  const fs::path tiles = root_ / "maps" / "tampered" / "tiles";
  std::ifstream list_file(dir / "tiles");
  const auto list = TerrainTiles::Parse(std::string(std::istreambuf_iterator<char>(list_file), {}),
                                        dir / "tiles");
  ASSERT_TRUE(list.ok()) << Why(list);

  const fs::path model_tile = tiles / list->model.back();
  fs::resize_file(model_tile, fs::file_size(model_tile) / 2);
  const auto truncated = store_->LoadModel("tampered", version);
  ASSERT_TRUE(Fails(truncated, ServiceErrorCode::kMapCorrupted)) << Why(truncated);
  EXPECT_THAT(truncated.error().message, HasSubstr(model_tile.string()));
  EXPECT_THAT(truncated.error().message, HasSubstr("does not hold the bytes its name says"));
  // As an edit reads it.
  const auto files = store_->OpenVersion("tampered", version);
  ASSERT_TRUE(files.ok() && files->tiles.has_value()) << Why(files);
  EXPECT_TRUE(Fails(LoadTiledModel(*files->tiles, "v"), ServiceErrorCode::kMapCorrupted));

  const fs::path cloud_tile = tiles / list->cloud.front();
  fs::remove(cloud_tile);
  const auto short_cloud = store_->LoadCloud("tampered", version);
  ASSERT_TRUE(Fails(short_cloud, ServiceErrorCode::kMapCorrupted)) << Why(short_cloud);
  EXPECT_THAT(short_cloud.error().message, HasSubstr(list->cloud.front()));
  EXPECT_THAT(short_cloud.error().message, HasSubstr("removed by hand"));

  std::ofstream(dir / "tiles") << "strata tiles 1\nheader nonsense\n";
  const auto bad_list = store_->LoadModel("tampered", version);
  ASSERT_TRUE(Fails(bad_list, ServiceErrorCode::kMapCorrupted)) << Why(bad_list);
  EXPECT_THAT(bad_list.error().message, HasSubstr("is not a list of tiles"));

  std::ofstream(root_ / "maps" / "tampered" / "head") << "not a version\n";
  EXPECT_TRUE(Fails(store_->Versions("tampered"), ServiceErrorCode::kMapCorrupted));
  // Deleting is the way out.
  EXPECT_TRUE(store_->Delete("tampered").ok());
}

TEST_F(MapStoreTest, CollectsOnlyStaleLeftovers) {
  const std::string kept = Create("m", cloud());
  const std::string orphan = Put(*store_, "m", Variant(1));  // Lost a race, say.
  const std::string young = Put(*store_, "m", Variant(2));   // About to be published.
  Put(*store_, "headless", cloud());                         // Its writer died before publishing.
  const fs::path versions = root_ / "maps" / "m" / "versions";
  EXPECT_EQ(store_->CollectGarbage(), 0);  // Everything is young: maybe live writers'.
  MakeStale(versions / kept);
  MakeStale(versions / orphan);
  MakeStale(root_ / "maps" / "headless");

  EXPECT_EQ(store_->CollectGarbage(), 2);
  EXPECT_TRUE(fs::exists(versions / kept));
  EXPECT_FALSE(fs::exists(versions / orphan));
  EXPECT_TRUE(fs::exists(versions / young));
  EXPECT_FALSE(fs::exists(root_ / "maps" / "headless"));
  EXPECT_TRUE(store_->PublishUpdate("m", kept, young, 3).ok());
  store_->WaitForRemovals();
  EXPECT_THAT(Entries(root_ / "trash"), IsEmpty());
  // The orphan's terrain, which no version names, goes once it is stale too.
  const fs::path terrains = root_ / "maps" / "m" / "terrains";
  EXPECT_TRUE(fs::exists(terrains / orphan));
  MakeStale(terrains / orphan);
  MakeStale(terrains / kept);  // Named by a version: stays however old.
  const std::size_t tiles_before = StoredTiles("m").size();
  // The terrain, then the tiles only it listed (its cloud's, which moved a point).
  EXPECT_GT(store_->CollectGarbage(), 1);
  EXPECT_FALSE(fs::exists(terrains / orphan));
  EXPECT_TRUE(fs::exists(terrains / kept));
  EXPECT_LT(StoredTiles("m").size(), tiles_before);
  EXPECT_EQ(StoredTiles("m"), ListedTiles("m"));
}

// The measure: a version costs what it changed. An obstacle set down in a garage of
// 12 tiles writes the few tiles it changed (bytes at most twice theirs, with the terrain's
// list), shares the rest, and once the old version is pruned its own tiles go with it.
TEST_F(MapStoreTest, AnEditedTerrainWritesOnlyTheTilesItChanged) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  const PointCloud cloud = GenerateParkingGarage(1, 0.2);
  const auto model = TerrainModel::Assess(cloud, config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const std::string first = MapStore::VersionOf(cloud, config, {});
  TileWrites writes;
  const CutTerrain base = CutIntoTiles(**model, cloud);
  ASSERT_TRUE(store_->PutTerrain("garage", first, base, &writes).ok());
  EXPECT_EQ(writes.written, static_cast<int>(base.tiles.size()));
  EXPECT_EQ(writes.shared, 0);
  ASSERT_TRUE(store_->PutVersion("garage", first, first, "{}").ok());
  ASSERT_TRUE(store_->PublishNew("garage", first).ok());

  const std::vector<MapEdit> edits = {
      {MapEdit::Kind::kAddObstacle,
       BoxPrism(Eigen::AlignedBox3d(Eigen::Vector3d(6, 6, 0), Eigen::Vector3d(8, 8, 1)))}};
  const auto edited = ApplyEdits(cloud, edits, **model);
  ASSERT_TRUE(edited.ok()) << edited.error().message;
  const auto reassessed = ReassessRegion(**model, cloud, *edited, EditBounds(edits));
  ASSERT_TRUE(reassessed.ok()) << reassessed.error().message;
  const std::string next = MapStore::VersionOf(*edited, config, {});
  // As an edit writes it: only the tiles of the reassessed columns cut, the others named as
  // the base's. A model tile and a cloud tile kept so are gone meanwhile (as if collected):
  // the edit is refused as one the map changed under, naming the tile, and nothing of its
  // terrain is listed; with them back it is put.
  const BaseTiles kept{base.list, TilesTouching(model->get()->grid(), reassessed->changed_columns)};
  ASSERT_LT(kept.changed.size(), base.list.model.size() / 2);
  const CutTerrain partial = CutIntoTiles(*reassessed->model, *edited, &kept);
  const fs::path tiles_dir = root_ / "maps" / "garage" / "tiles";
  for (const std::vector<std::string>* section : {&base.list.model, &base.list.cloud}) {
    std::string removed;
    for (std::size_t t = 0; t < section->size() && removed.empty(); ++t) {
      if (!std::binary_search(kept.changed.begin(), kept.changed.end(), t)) removed = (*section)[t];
    }
    ASSERT_FALSE(removed.empty());
    const fs::path moved = root_ / "aside";
    fs::rename(tiles_dir / removed, moved);
    const ServiceStatus refused = store_->PutTerrain("garage", next, partial, &writes);
    ASSERT_TRUE(Fails(refused, ServiceErrorCode::kMapChanged)) << Why(refused);
    EXPECT_EQ(refused.error().metadata.at("missing_tile"), removed);
    EXPECT_FALSE(store_->HasTerrain("garage", next));
    fs::rename(moved, tiles_dir / removed);
  }
  for (const auto& [name, bytes] : partial.tiles) fs::remove(tiles_dir / name);  // Left above.
  ASSERT_TRUE(store_->PutTerrain("garage", next, partial, &writes).ok());

  std::set<std::string> base_names;
  std::uint64_t base_bytes = 0;
  for (const auto& [name, bytes] : base.tiles) {
    base_names.insert(name);
    base_bytes += bytes.size();
  }
  std::uint64_t changed_bytes = 0;
  int changed = 0;
  const CutTerrain cut = CutIntoTiles(*reassessed->model, *edited);
  for (const auto& [name, bytes] : cut.tiles) {
    if (base_names.contains(name)) continue;
    ++changed;
    changed_bytes += bytes.size();
  }
  // The header, and at most the 2 × 2 model and cloud tiles around the block.
  EXPECT_GE(changed, 3);
  EXPECT_LE(changed, 9);
  EXPECT_EQ(partial.list.Format(), cut.list.Format());
  EXPECT_LE(partial.tiles.size(), 2 * kept.changed.size() + 1);
  EXPECT_EQ(writes.written, changed);
  EXPECT_EQ(writes.shared, static_cast<int>(cut.tiles.size()) - changed);
  EXPECT_LE(writes.bytes_written, 2 * changed_bytes);
  EXPECT_LT(changed_bytes, base_bytes / 2);

  ASSERT_TRUE(store_->PutVersion("garage", next, next, "{}").ok());
  // On a replica that holds the base, the tiles both list are taken from its model: one of
  // them gone from the store is not missed, and the model is the edited one, byte for byte.
  std::string shared_tile;
  for (std::size_t t = 0; t < base.list.model.size() && shared_tile.empty(); ++t) {
    if (base.list.model[t] == cut.list.model[t]) shared_tile = base.list.model[t];
  }
  ASSERT_FALSE(shared_tile.empty());
  fs::rename(tiles_dir / shared_tile, root_ / "aside");
  EXPECT_FALSE(store_->LoadModel("garage", next).ok());
  std::optional<CellBox> not_shared;
  const auto from_held = store_->LoadModel("garage", next, *model, first, &not_shared);
  ASSERT_TRUE(from_held.ok()) << Why(from_held);
  EXPECT_TRUE(SerializeModel(**from_held) == SerializeModel(*reassessed->model));
  // Where the two may differ: the blocks of the tiles they do not share, which hold every
  // column the edit reassessed and not the whole garage. The base's graph patched there is
  // the one a build of the edited model makes (the replica's graph, made ahead).
  ASSERT_TRUE(not_shared.has_value());
  const CellBox& reassessed_columns = reassessed->changed_columns;
  EXPECT_TRUE(
      (not_shared->min.head<2>().array() <= reassessed_columns.min.head<2>().array()).all());
  EXPECT_TRUE(
      (not_shared->max.head<2>().array() >= reassessed_columns.max.head<2>().array()).all());
  EXPECT_LT(not_shared->CellCount(), CellBox::Whole((*model)->grid()).CellCount() / 2);
  const TraversabilityParams params;
  const SurfaceGraph base_graph = SurfaceGraph::Build(**model, params).value();
  const SurfaceGraph patched = SurfaceGraph::Patch(base_graph, **from_held, *not_shared).value();
  const SurfaceGraph built = SurfaceGraph::Build(**from_held, params).value();
  EXPECT_EQ(patched.node_count(), built.node_count());
  EXPECT_EQ(patched.component_count(), built.component_count());
  EXPECT_TRUE(std::ranges::equal(patched.components(), built.components()));
  EXPECT_TRUE(std::ranges::equal(patched.edge_distances(), built.edge_distances()));
  fs::rename(root_ / "aside", tiles_dir / shared_tile);
  ASSERT_TRUE(store_->PublishUpdate("garage", first, next, 1).ok());
  store_->WaitForRemovals();
  EXPECT_EQ(StoredTiles("garage"), ListedTiles("garage"));
  const auto loaded = store_->LoadModel("garage", next);
  ASSERT_TRUE(loaded.ok()) << Why(loaded);
  EXPECT_TRUE(SerializeModel(**loaded) == SerializeModel(*reassessed->model));
  const auto loaded_cloud = store_->LoadCloud("garage", next);
  ASSERT_TRUE(loaded_cloud.ok()) << Why(loaded_cloud);
  EXPECT_EQ(Sorted(*loaded_cloud), Sorted(*edited));
}

TEST_F(MapStoreTest, GraphsAreKeptBesideTheirTerrainAndGoWithIt) {
  const std::string first = Create("g", cloud());
  const auto built = SurfaceGraph::Build(model(), TraversabilityParams{});
  ASSERT_TRUE(built.ok()) << built.error().message;
  const SurfaceGraph& graph = *built;
  TraversabilityParams other;
  other.body_height_m = 0.4;
  EXPECT_FALSE(store_->LoadGraph("g", first, model(), TraversabilityParams{})->has_value());

  ASSERT_TRUE(store_->PutGraph("g", first, graph).ok());
  ASSERT_TRUE(store_->PutGraph("g", first, graph).ok());  // Again: over the first, by rename.
  const fs::path graphs = root_ / "maps" / "g" / "graphs" / first;
  ASSERT_EQ(Entries(graphs).size(), 1u);
  EXPECT_THAT(Entries(root_ / "tmp"), IsEmpty());
  const auto loaded = store_->LoadGraph("g", first, model(), TraversabilityParams{});
  ASSERT_TRUE(loaded.ok()) << Why(loaded);
  ASSERT_TRUE(loaded->has_value());
  EXPECT_EQ(SerializeGraph(**loaded), SerializeGraph(graph));
  EXPECT_FALSE(store_->LoadGraph("g", first, model(), other)->has_value());  // Another robot's.

  // A damaged file: refused naming it (the caller builds the graph and puts it again).
  const fs::path file = Entries(graphs).front();
  std::ofstream(file, std::ios::binary | std::ios::trunc) << "STRATAGR damaged";
  const auto damaged = store_->LoadGraph("g", first, model(), TraversabilityParams{});
  ASSERT_TRUE(Fails(damaged, ServiceErrorCode::kMapCorrupted)) << Why(damaged);
  EXPECT_THAT(damaged.error().message, HasSubstr(file.string()));
  ASSERT_TRUE(store_->PutGraph("g", first, graph).ok());
  EXPECT_TRUE(store_->LoadGraph("g", first, model(), TraversabilityParams{})->has_value());

  EXPECT_TRUE(Fails(store_->PutGraph("../g", first, graph), ErrorCode::kInvalidInput));
  EXPECT_TRUE(Fails(store_->LoadGraph("g", "../" + first, model(), TraversabilityParams{}),
                    ErrorCode::kInvalidInput));

  // The terrain pruned: its graphs go with it.
  const std::string second = Put(*store_, "g", Variant(1));
  ASSERT_TRUE(store_->PutGraph("g", second, graph).ok());
  ASSERT_TRUE(store_->PublishUpdate("g", first, second, 1).ok());
  store_->WaitForRemovals();
  EXPECT_FALSE(fs::exists(graphs));
  EXPECT_TRUE(fs::exists(root_ / "maps" / "g" / "graphs" / second));

  // Graphs of a terrain no version names (kept while a lost race discarded it): a leftover,
  // removed once stale, like an unnamed terrain.
  const std::string lost = VersionOf(Variant(2));
  ASSERT_TRUE(store_->PutGraph("g", lost, graph).ok());
  EXPECT_EQ(store_->CollectGarbage(), 0);
  MakeStale(root_ / "maps" / "g" / "graphs" / lost);
  MakeStale(root_ / "maps" / "g" / "graphs" / second);  // Its terrain is named: stays.
  EXPECT_EQ(store_->CollectGarbage(), 1);
  EXPECT_FALSE(fs::exists(root_ / "maps" / "g" / "graphs" / lost));
  EXPECT_TRUE(fs::exists(root_ / "maps" / "g" / "graphs" / second));
}

TEST_F(MapStoreTest, AWriterKilledWhileKeepingAGraphLeavesTheKeptOneWhole) {
  const std::string terrain = Create("g", cloud());
  const auto built = SurfaceGraph::Build(model(), TraversabilityParams{});
  ASSERT_TRUE(built.ok()) << built.error().message;
  ASSERT_TRUE(store_->PutGraph("g", terrain, *built).ok());
  const std::string kept = SerializeGraph(*built);
  const fs::path graphs = root_ / "maps" / "g" / "graphs" / terrain;
  // Another process writes the same graph over and over (as replicas that built it do) and is
  // killed at an arbitrary moment of that, ten times: each time the kept graph is whole.
  for (int round = 0; round < 10; ++round) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      auto store = MapStore::Open(root_);
      while (store.ok() && (*store)->PutGraph("g", terrain, *built).ok()) {
      }
      ::_exit(1);
    }
    // Killed 0.5 to 5 ms after it started: a write of this graph takes about that long.
    const auto until =
        std::chrono::steady_clock::now() + std::chrono::microseconds(500 * (round + 1));
    while (std::chrono::steady_clock::now() < until) std::this_thread::yield();
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer stopped by itself";
    ASSERT_EQ(Entries(graphs).size(), 1u);
    const auto loaded = store_->LoadGraph("g", terrain, model(), TraversabilityParams{});
    ASSERT_TRUE(loaded.ok()) << "round " << round << ": " << Why(loaded);
    ASSERT_TRUE(loaded->has_value());
    ASSERT_EQ(SerializeGraph(**loaded), kept) << "round " << round;
  }
  // What the writers left is temporaries (of a graph, or of Open's probe), removed once stale.
  for (const fs::path& left : Entries(root_ / "tmp")) {
    const std::string name = left.filename().string();
    EXPECT_TRUE(name.starts_with("graph.") || name.starts_with("probe.")) << left;
    MakeStale(left);
  }
  store_->CollectGarbage();
  EXPECT_THAT(Entries(root_ / "tmp"), IsEmpty());
}

TEST_F(MapStoreTest, AGraphOneReplicaBuiltIsLoadedByAnotherInsteadOfBuilt) {
  const std::string terrain = Create("shared", cloud());
  auto other_store = MapStore::Open(root_);  // Another replica's view of the same volume.
  ASSERT_TRUE(other_store.ok()) << Why(other_store);
  std::shared_ptr<MapStore> here(std::move(store_));
  std::shared_ptr<MapStore> there(std::move(*other_store));
  const auto writer = std::make_shared<GraphWriter>();
  const auto model_here = std::make_shared<const TerrainModel>(model());
  const PlanningMap first(model_here, {}, 0,
                          std::make_shared<StoredGraphs>(here, writer, "shared", terrain));
  const auto built = first.Graph(TraversabilityParams{});
  ASSERT_TRUE(built.ok()) << built.error().message;
  writer->WaitIdle();  // Kept in the background: no plan waits for the write.
  ASSERT_EQ(Entries(root_ / "maps" / "shared" / "graphs" / terrain).size(), 1u);

  // The other replica's map of the same terrain finds it there.
  const auto model_there = std::make_shared<const TerrainModel>(model());
  const auto found =
      StoredGraphs(there, writer, "shared", terrain).Find(*model_there, TraversabilityParams{});
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(SerializeGraph(*found), SerializeGraph(**built));
  // A damaged one is not found (the map builds the graph and keeps it again).
  std::ofstream(Entries(root_ / "maps" / "shared" / "graphs" / terrain).front(),
                std::ios::binary | std::ios::trunc)
      << "x";
  const PlanningMap second(model_there, {}, 0,
                           std::make_shared<StoredGraphs>(there, writer, "shared", terrain));
  ASSERT_TRUE(second.Graph(TraversabilityParams{}).ok());
  writer->WaitIdle();
  EXPECT_TRUE(
      there->LoadGraph("shared", terrain, *model_there, TraversabilityParams{})->has_value());
  store_ = std::unique_ptr<MapStore>();  // TearDown resets it.
}

}  // namespace
}  // namespace strata::server
