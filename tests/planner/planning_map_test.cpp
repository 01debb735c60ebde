// PlanningMap's graph cache: keyed by the whole TraversabilityParams, so every field of it
// decides which graph a plan gets.
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "strata/planner.hpp"

namespace strata {
namespace {

std::shared_ptr<const TerrainModel> FlatFloor() {
  PointCloud cloud;
  for (double x = 0; x <= 3.0 + 1e-9; x += 0.05) {
    for (double y = 0; y <= 3.0 + 1e-9; y += 0.05) {
      cloud.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
    }
  }
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  return TerrainModel::Assess(cloud, config).value();
}

TEST(PlanningMap, OneGraphPerDistinctTraversabilityParams) {
  const PlanningMap map(FlatFloor());
  const TraversabilityParams base = BuiltinProfile("differential")->Traversability();
  const auto first = map.Graph(base).value();
  EXPECT_EQ(map.Graph(base).value(), first);
  EXPECT_EQ(map.Graph(RobotProfile{}.Traversability()).value(), first);
  const std::size_t one_graph = map.MemoryBytes();

  const struct {
    std::string field;
    std::function<void(TraversabilityParams*)> edit;
  } changes[] = {
      {"reference_height_m", [](TraversabilityParams* p) { p->reference_height_m += 0.01; }},
      {"body_height_m", [](TraversabilityParams* p) { p->body_height_m += 0.01; }},
      {"max_tilt_rad", [](TraversabilityParams* p) { p->max_tilt_rad -= 0.01; }},
      {"max_step_m", [](TraversabilityParams* p) { p->max_step_m += 0.01; }},
  };
  for (const auto& change : changes) {
    TraversabilityParams other = base;
    change.edit(&other);
    const auto graph = map.Graph(other).value();
    EXPECT_NE(graph, first) << change.field;
    EXPECT_EQ(graph->params(), other) << change.field;
    EXPECT_EQ(map.Graph(other).value(), graph) << change.field;
  }
  EXPECT_GT(map.MemoryBytes(), one_graph);
}

TEST(PlanningMap, InvalidParamsAreRefusedBeforeTheCache) {
  const PlanningMap map(FlatFloor());
  TraversabilityParams bad;
  bad.max_step_m = std::numeric_limits<double>::quiet_NaN();
  auto graph = map.Graph(bad);
  ASSERT_FALSE(graph.ok());
  EXPECT_EQ(graph.error().field, "traversability.max_step_m");
  EXPECT_EQ(map.MemoryBytes(), map.model().MemoryBytes());
}

// Distinct params, hence distinct graphs of the same size on a flat floor.
TraversabilityParams Variant(int i) {
  TraversabilityParams params = BuiltinProfile("differential")->Traversability();
  params.max_step_m += 0.01 * i;
  return params;
}

TEST(PlanningMap, GraphsPastTheBoundGoLeastRecentlyUsedFirstNeverWhileHeld) {
  const std::shared_ptr<const TerrainModel> model = FlatFloor();
  const std::size_t one = PlanningMap(model).Graph(Variant(0)).value()->MemoryBytes();
  const PlanningMap map(model, {}, 2 * one + one / 2);  // Room for two graphs.
  {
    const auto held = map.Graph(Variant(0)).value();  // Oldest, but a plan runs on it.
    ASSERT_TRUE(map.Graph(Variant(1)).ok());
    ASSERT_TRUE(map.Graph(Variant(2)).ok());  // Three: 1 goes, 0 is held.
    EXPECT_EQ(map.GraphCount(), 2u);
    EXPECT_EQ(map.Graph(Variant(0)).value(), held);  // Still the same graph.
    EXPECT_LE(map.MemoryBytes(), model->MemoryBytes() + 2 * one);
  }
  // Recency: 0 (just asked), then 2. Asking 2 again makes 0 the oldest, and 3 drops it.
  ASSERT_TRUE(map.Graph(Variant(2)).ok());
  ASSERT_TRUE(map.Graph(Variant(3)).ok());
  EXPECT_EQ(map.GraphCount(), 2u);
  EXPECT_LE(map.MemoryBytes(), model->MemoryBytes() + 2 * one);
  // A dropped graph is built again when asked for.
  EXPECT_EQ(map.Graph(Variant(0)).value()->params(), Variant(0));

  // Without a bound, every graph stays.
  const PlanningMap unbounded(model);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(unbounded.Graph(Variant(i)).ok());
  EXPECT_EQ(unbounded.GraphCount(), 4u);
}

TEST(PlanningMap, NewZonesKeepTheGraphsAndTheirBound) {
  const std::shared_ptr<const TerrainModel> model = FlatFloor();
  const std::size_t one = PlanningMap(model).Graph(Variant(0)).value()->MemoryBytes();
  auto map = std::make_shared<PlanningMap>(model, std::vector<Prism>{}, 2 * one + one / 2);
  const SurfaceGraph* first = map->Graph(Variant(0)).value().get();
  const SurfaceGraph* second = map->Graph(Variant(1)).value().get();
  const std::vector<Prism> zones = {Prism{{{1, 1}, {2, 1}, {2, 2}}, -1, 1}};
  const std::shared_ptr<const PlanningMap> zoned = map->WithKeepOut(zones);
  EXPECT_EQ(&zoned->model(), &map->model());
  ASSERT_EQ(zoned->keep_out().size(), 1u);
  EXPECT_EQ(zoned->keep_out()[0].polygon_m, zones[0].polygon_m);
  EXPECT_TRUE(map->keep_out().empty());
  EXPECT_EQ(zoned->GraphCount(), 2u);
  EXPECT_EQ(zoned->MemoryBytes(), map->MemoryBytes());

  map.reset();  // The copy alone holds the graphs now.
  EXPECT_EQ(zoned->Graph(Variant(1)).value().get(), second);  // Not built again.
  EXPECT_EQ(zoned->Graph(Variant(0)).value().get(), first);
  // The bound came along: a third graph drops the least recently used one (1).
  ASSERT_TRUE(zoned->Graph(Variant(2)).ok());
  EXPECT_EQ(zoned->GraphCount(), 2u);
  EXPECT_EQ(zoned->Graph(Variant(0)).value().get(), first);
}

TEST(PlanningMap, AFailedBuildIsNotKept) {
  const PlanningMap map(FlatFloor());
  TraversabilityParams steep = Variant(0);
  steep.max_tilt_rad = map.model().config().ground.max_tilt_rad + 0.1;  // Valid, but not here.
  for (int attempt = 0; attempt < 3; ++attempt) {
    auto graph = map.Graph(steep);
    ASSERT_FALSE(graph.ok());
    EXPECT_EQ(graph.error().field, "traversability.max_tilt_rad");
  }
  EXPECT_EQ(map.GraphCount(), 0u);
}

TEST(PlanningMap, AStoppedBuildFailsCancelledAndIsBuiltAgainByTheNextCall) {
  const PlanningMap map(FlatFloor());
  int polls = 0;
  // Stops at the second poll: the build is under way, not refused up front.
  const auto graph = map.Graph(Variant(0), [&polls] { return ++polls >= 2; });
  ASSERT_FALSE(graph.ok());
  EXPECT_EQ(graph.error().code, ErrorCode::kCancelled);
  EXPECT_EQ(polls, 2);
  EXPECT_EQ(map.GraphCount(), 0u);
  const auto again = map.Graph(Variant(0), [] { return false; });
  ASSERT_TRUE(again.ok());
  EXPECT_GT((*again)->node_count(), 0);
}

// An edited map makes its graph from the one its base holds (SurfaceGraph::Patch), and builds
// it when the base holds none; either way the graph is the edited model's.
TEST(PlanningMap, AGraphPatchedFromTheBaseMapIsTheEditedModelsAndIsBuiltWhenTheBaseHasNone) {
  const std::shared_ptr<const TerrainModel> floor = FlatFloor();
  PointCloud cloud;
  for (double x = 0; x <= 3.0 + 1e-9; x += 0.05) {
    for (double y = 0; y <= 3.0 + 1e-9; y += 0.05) {
      if (x > 1.4 && x < 1.6) continue;  // A gap splits the floor in two.
      cloud.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
    }
  }
  const std::shared_ptr<const TerrainModel> walled =
      TerrainModel::Assess(cloud, floor->config()).value();
  ASSERT_EQ(walled->grid().size, floor->grid().size);  // Else nothing could be patched.
  const TraversabilityParams params = RobotProfile{}.Traversability();
  const CellBox changed = CellBox::Whole(walled->grid());
  const PlanningMap base(floor);
  const PlanningMap without_graph(walled);
  const auto built_without_base = without_graph.GraphPatchedFrom(base, changed, params).value();
  EXPECT_EQ(built_without_base->component_count(), 2);
  ASSERT_EQ(base.GraphCount(), 0U);  // Nothing to patch from: built.

  (void)base.Graph(params).value();
  const PlanningMap edited(walled);
  const auto patched = edited.GraphPatchedFrom(base, changed, params).value();
  EXPECT_EQ(patched->component_count(), 2);
  EXPECT_EQ(patched->node_count(), built_without_base->node_count());
  EXPECT_EQ(edited.Graph(params).value(), patched);  // Kept as any graph.
}

}  // namespace
}  // namespace strata
