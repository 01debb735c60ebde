#include "strata/io/saved_graph.hpp"

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <xxhash.h>

#include "strata/io/saved_model.hpp"
#include "strata/planner.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const TerrainModel> Assess(double resolution_m) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  auto model = TerrainModel::Assess(GenerateTwoLevelRamp(2, 0.2), config);
  EXPECT_TRUE(model.ok()) << model.error().message;
  return model.ok() ? *model : nullptr;
}

// What `graph` holds beyond the model, read back through its accessors.
SurfaceGraph::Parts PartsOf(const SurfaceGraph& graph) {
  SurfaceGraph::Parts parts;
  parts.params = graph.params();
  for (const SurfaceGraph::Node& node : graph.nodes())
    parts.clearance_m.push_back(node.clearance_m);
  parts.components.assign(graph.components().begin(), graph.components().end());
  parts.component_count = graph.component_count();
  parts.edge_distance_m.assign(graph.edge_distances().begin(), graph.edge_distances().end());
  parts.open_ground_clearance_m = graph.open_ground_clearance_m();
  parts.landmark_count = graph.landmark_count();
  parts.landmark_distance.assign(graph.landmark_distances().begin(),
                                 graph.landmark_distances().end());
  return parts;
}

class SavedGraph : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = new std::shared_ptr<const TerrainModel>(Assess(0.25));
    auto graph = SurfaceGraph::Build(**model_, TraversabilityParams{});
    ASSERT_TRUE(graph.ok()) << graph.error().message;
    graph_ = new SurfaceGraph(std::move(graph).value());
    bytes_ = new std::string(SerializeGraph(*graph_));
  }
  static void TearDownTestSuite() {
    delete graph_;
    delete bytes_;
    delete model_;
  }
  static const TerrainModel& model() { return **model_; }
  static const SurfaceGraph& graph() { return *graph_; }
  static const std::string& bytes() { return *bytes_; }

  static Error RefusalOf(std::string_view bytes) {
    const auto loaded = DeserializeGraph(bytes, model(), "test.stratagraph");
    EXPECT_FALSE(loaded.ok());
    if (loaded.ok()) return Error{ErrorCode::kInvalidInput, "loaded"};
    EXPECT_EQ(loaded.error().code, ErrorCode::kMapLoadFailed);
    EXPECT_THAT(loaded.error().message, HasSubstr("test.stratagraph"));
    return loaded.error();
  }

 private:
  static std::shared_ptr<const TerrainModel>* model_;
  static SurfaceGraph* graph_;
  static std::string* bytes_;
};

std::shared_ptr<const TerrainModel>* SavedGraph::model_ = nullptr;
SurfaceGraph* SavedGraph::graph_ = nullptr;
std::string* SavedGraph::bytes_ = nullptr;

TEST_F(SavedGraph, RoundTripsEveryNodeAndTheSameBytes) {
  const auto loaded = DeserializeGraph(bytes(), model(), "ramp");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const SurfaceGraph& copy = *loaded;
  ASSERT_GT(graph().node_count(), 1000);
  ASSERT_GT(graph().landmark_count(), 0);  // Landmarks are saved too: check they come back.
  ASSERT_EQ(copy.node_count(), graph().node_count());
  EXPECT_EQ(copy.params(), graph().params());
  EXPECT_EQ(copy.component_count(), graph().component_count());
  EXPECT_EQ(copy.open_ground_clearance_m(), graph().open_ground_clearance_m());
  for (int n = 0; n < graph().node_count(); ++n) {
    ASSERT_EQ(copy.position(n), graph().position(n)) << n;
    ASSERT_EQ(copy.level(n), graph().level(n)) << n;
    ASSERT_EQ(copy.clearance(n), graph().clearance(n)) << n;
    ASSERT_EQ(copy.component(n), graph().component(n)) << n;
    ASSERT_EQ(copy.edge_distance(n), graph().edge_distance(n)) << n;
    std::vector<int> a, b;
    graph().ForEachNeighbor(n, [&](int m) { a.push_back(m); });
    copy.ForEachNeighbor(n, [&](int m) { b.push_back(m); });
    ASSERT_EQ(a, b) << n;
  }
  const int last = graph().node_count() - 1;
  EXPECT_EQ(copy.LandmarkBound(0, last, MoveCostTerms{}),
            graph().LandmarkBound(0, last, MoveCostTerms{}));
  EXPECT_EQ(SerializeGraph(copy), bytes());
}

// An archive holding graphs in memory, counting what a planning map asks of it.
class MemoryArchive final : public GraphArchive {
 public:
  std::optional<SurfaceGraph> Find(const TerrainModel& model,
                                   const TraversabilityParams& params) const override {
    std::lock_guard lock(mutex_);
    ++finds_;
    const auto kept = kept_.find(SavedGraphKey(params));
    if (kept == kept_.end()) return std::nullopt;
    auto graph = DeserializeGraph(kept->second, model, "archive");
    EXPECT_TRUE(graph.ok()) << graph.error().message;
    if (!graph.ok()) return std::nullopt;
    return std::move(graph).value();
  }
  bool Holds(const TraversabilityParams& params) const override {
    std::lock_guard lock(mutex_);
    return kept_.contains(SavedGraphKey(params));
  }
  void Keep(std::shared_ptr<const TerrainModel>,
            std::shared_ptr<const SurfaceGraph> graph) const override {
    std::lock_guard lock(mutex_);
    ++keeps_;
    kept_[SavedGraphKey(graph->params())] = SerializeGraph(*graph);
  }
  int finds() const {
    std::lock_guard lock(mutex_);
    return finds_;
  }
  int keeps() const {
    std::lock_guard lock(mutex_);
    return keeps_;
  }

 private:
  mutable std::mutex mutex_;
  mutable std::map<std::string, std::string> kept_;  // By SavedGraphKey.
  mutable int finds_ = 0;
  mutable int keeps_ = 0;
};

TEST(SavedGraphPlans, AGraphKeptByOneMapIsLoadedByTheNextAndPlansAlike) {
  const std::shared_ptr<const TerrainModel> model = Assess(0.25);
  ASSERT_NE(model, nullptr);
  const auto archive = std::make_shared<MemoryArchive>();
  const PlanningMap first(model, {}, 0, archive);
  PlanRequest request;
  request.start.position_m = {1, 1, 0.3};
  request.goal.position_m = {1, 3, 3.3};  // Up the ramp to the deck.
  request.options.time_budget_s = 30;
  const auto built = Plan(first, request);
  ASSERT_TRUE(built.ok()) << built.error().message;
  EXPECT_EQ(archive->finds(), 1);  // Looked for first,
  EXPECT_EQ(archive->keeps(), 1);  // then built and kept.
  ASSERT_TRUE(Plan(first, request).ok());
  EXPECT_EQ(archive->finds(), 1);  // Held since: neither looked for nor kept again.
  EXPECT_EQ(archive->keeps(), 1);

  // Another map of the same model (another replica's) loads it instead of building it, and
  // plans the same trajectory bit for bit.
  const PlanningMap second(model, {}, 0, archive);
  const auto loaded = Plan(second, request);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(archive->finds(), 2);
  EXPECT_EQ(archive->keeps(), 1);
  ASSERT_EQ(loaded->trajectory.pieces.size(), built->trajectory.pieces.size());
  for (std::size_t i = 0; i < built->trajectory.pieces.size(); ++i) {
    EXPECT_EQ(loaded->trajectory.pieces[i].duration_s, built->trajectory.pieces[i].duration_s);
    EXPECT_EQ(loaded->trajectory.pieces[i].coefficients, built->trajectory.pieces[i].coefficients);
  }
  // A map with other zones keeps the archive (zones are not part of graphs): its graphs for
  // other robots are looked for there too.
  const auto zoned = second.WithKeepOut({});
  TraversabilityParams low;
  low.body_height_m = 0.4;
  ASSERT_TRUE(zoned->Graph(low).ok());
  EXPECT_EQ(archive->finds(), 3);
  EXPECT_EQ(archive->keeps(), 2);
}

// A map patching its graph from another version's (GraphPatchedFrom) does not load the
// archive's: a patch is faster. It keeps the patched graph only where the archive holds none.
TEST(SavedGraphPlans, AGraphPatchedFromAnotherVersionIsNotLoadedAndKeptOnlyWhereMissing) {
  const std::shared_ptr<const TerrainModel> model = Assess(0.25);
  ASSERT_NE(model, nullptr);
  const TraversabilityParams params = RobotProfile{}.Traversability();
  const CellBox changed{{2, 2}, {5, 6}};  // The versions are alike: any columns do.

  const auto archive = std::make_shared<MemoryArchive>();
  const PlanningMap base(model, {}, 0, archive);
  ASSERT_TRUE(base.Graph(params).ok());
  EXPECT_EQ(archive->finds(), 1);
  EXPECT_EQ(archive->keeps(), 1);
  const PlanningMap next(model, {}, 0, archive);
  const auto patched = next.GraphPatchedFrom(base, changed, params);
  ASSERT_TRUE(patched.ok()) << patched.error().message;
  EXPECT_EQ(SerializeGraph(**patched), SerializeGraph(*base.Graph(params).value()));
  EXPECT_EQ(archive->finds(), 1);  // Not looked for,
  EXPECT_EQ(archive->keeps(), 1);  // and not written again.

  const auto empty = std::make_shared<MemoryArchive>();
  const PlanningMap elsewhere(model, {}, 0, empty);
  ASSERT_TRUE(elsewhere.GraphPatchedFrom(base, changed, params).ok());
  EXPECT_EQ(empty->finds(), 0);
  EXPECT_EQ(empty->keeps(), 1);  // Kept for the replicas that hold no version to patch from.
}

TEST_F(SavedGraph, SavesToAFileAndLoadsFromIt) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("strata_saved_graph_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "ramp.stratagraph").string();
  ASSERT_TRUE(SaveGraph(graph(), path).ok());
  ASSERT_TRUE(SaveGraph(graph(), path).ok());  // Over the first: atomically, by rename.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
  const auto loaded = LoadGraph(path, model());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(SerializeGraph(*loaded), bytes());
  const Status unwritable = SaveGraph(graph(), (dir / "missing" / "x.stratagraph").string());
  ASSERT_FALSE(unwritable.ok());
  EXPECT_THAT(unwritable.error().message, HasSubstr("cannot write the saved graph"));
  const auto missing = LoadGraph((dir / "nothing.stratagraph").string(), model());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kMapLoadFailed);
  std::filesystem::remove_all(dir);
}

TEST_F(SavedGraph, RefusesForeignFilesOtherVersionsTruncationsAndCorruption) {
  EXPECT_THAT(RefusalOf(SerializeModel(model())).message, HasSubstr("not a Strata saved graph"));
  EXPECT_THAT(RefusalOf("").message, HasSubstr("not a Strata saved graph"));
  for (const std::uint32_t version : {kSavedGraphFormatVersion - 1, kSavedGraphFormatVersion + 1}) {
    std::string other = bytes();
    std::memcpy(other.data() + 8, &version, 4);
    EXPECT_THAT(RefusalOf(other).message,
                HasSubstr("format version " + std::to_string(version) + ";"));
  }
  for (std::size_t n = 8; n < bytes().size(); n += bytes().size() / 97) {
    ASSERT_THAT(RefusalOf(std::string_view(bytes()).substr(0, n)).message, HasSubstr("truncated"))
        << n << " bytes";
  }
  // A flipped bit anywhere after the header: the checksum says so before anything is built.
  for (std::size_t at = 40; at < bytes().size() - 8; at += bytes().size() / 53) {
    std::string flipped = bytes();
    flipped[at] = static_cast<char>(flipped[at] ^ 0x10);
    ASSERT_THAT(RefusalOf(flipped).message, HasSubstr("checksum")) << "byte " << at;
  }
}

TEST_F(SavedGraph, RefusesTheGraphOfAnotherModel) {
  // The same scene assessed finer: another node count.
  const std::shared_ptr<const TerrainModel> finer = Assess(0.2);
  ASSERT_NE(finer, nullptr);
  const auto loaded = DeserializeGraph(bytes(), *finer, "coarse.stratagraph");
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kMapLoadFailed);
  EXPECT_THAT(loaded.error().message, HasSubstr("coarse.stratagraph"));
  EXPECT_THAT(loaded.error().message,
              HasSubstr("nodes where the model and the robot's parameters give"));
}

TEST_F(SavedGraph, PartsThatDoNotFitTheNodesAreRefused) {
  ASSERT_TRUE(SurfaceGraph::FromParts(model(), PartsOf(graph())).ok());
  const auto refusal = [&](SurfaceGraph::Parts parts) {
    const auto graph = SurfaceGraph::FromParts(model(), std::move(parts));
    EXPECT_FALSE(graph.ok());
    return graph.ok() ? Error{ErrorCode::kInvalidInput, "loaded"} : graph.error();
  };
  SurfaceGraph::Parts parts = PartsOf(graph());
  parts.components[7] = parts.component_count;
  EXPECT_THAT(refusal(parts).message, HasSubstr("node 7 has component"));
  parts = PartsOf(graph());
  parts.edge_distance_m[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THAT(refusal(parts).message, HasSubstr("node 3 has a clearance or rim distance"));
  parts = PartsOf(graph());
  parts.clearance_m.pop_back();
  EXPECT_THAT(refusal(parts).message, HasSubstr("nodes where the model"));
  parts = PartsOf(graph());
  parts.landmark_count = SurfaceGraph::kMaxLandmarks + 1;
  EXPECT_THAT(refusal(parts).message, HasSubstr("landmarks"));
  parts = PartsOf(graph());
  parts.landmark_distance[0] = -1;
  EXPECT_THAT(refusal(parts).message, HasSubstr("landmark distance"));
  // Params the map cannot serve: refused as Build refuses them.
  parts = PartsOf(graph());
  parts.params.max_tilt_rad = 1.5;
  const Error steep = refusal(parts);
  EXPECT_EQ(steep.code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(steep.message, HasSubstr("exceeds the map's ground filter"));
}

TEST(SavedGraphKey, NamesEqualParamsAlikeAndEveryFieldApart) {
  const TraversabilityParams params;
  const std::string key = SavedGraphKey(params);
  EXPECT_EQ(key.size(), 32u);
  EXPECT_EQ(SavedGraphKey(TraversabilityParams{}), key);
  std::vector<std::string> keys{key};
  int field = 0;
  ForEachField(params, [&](const char* name, const double&) {
    TraversabilityParams other = params;
    int k = 0;
    ForEachField(other, [&](const char*, double& value) {
      if (k++ == field) value += 0.01;
    });
    keys.push_back(SavedGraphKey(other));
    EXPECT_NE(keys.back(), key) << name;
    ++field;
  });
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(std::unique(keys.begin(), keys.end()), keys.end());
}

}  // namespace
}  // namespace strata
