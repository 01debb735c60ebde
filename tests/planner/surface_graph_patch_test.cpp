// SurfaceGraph::Patch against SurfaceGraph::Build on the edited model: after edits that cut a
// map in two, open a hole, join it again, and block the floor under a deck and the deck
// itself, the patched graph equals the built one value for value.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <gtest/gtest.h>

#include "strata/assessment/map_edit.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/prism.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata {
namespace {

TraversabilityParams Params() {
  TraversabilityParams p;
  p.reference_height_m = 0.3;
  p.body_height_m = 0.5;
  return p;
}

MapEdit BoxEdit(MapEdit::Kind kind, Eigen::Vector3d min, Eigen::Vector3d max) {
  return {kind, BoxPrism(Eigen::AlignedBox3d(min, max))};
}

// A cloud and its model, one version of a map.
struct Version {
  PointCloud cloud;
  std::shared_ptr<const TerrainModel> model;
  CellBox changed_columns;  // Against the version before it.
};

// `base` after `edit`, reassessed locally (ReassessRegion), as the map store makes a version.
Version Edited(const Version& base, const MapEdit& edit) {
  const std::vector<MapEdit> edits{edit};
  Version next;
  next.cloud = ApplyEdits(base.cloud, edits, *base.model).value();
  const Reassessment reassessed =
      ReassessRegion(*base.model, base.cloud, next.cloud, EditBounds(edits)).value();
  EXPECT_EQ(reassessed.path, ReassessmentPath::kLocal) << reassessed.full_reason;
  next.model = reassessed.model;
  next.changed_columns = reassessed.changed_columns;
  return next;
}

// Whether column c of `a` and `b` holds the same surfaces and the same field values.
bool SameColumn(const TerrainModel& a, const TerrainModel& b, int ix, int iy) {
  const std::span<const ColumnSurface> sa = a.surfaces().Column(ix, iy);
  const std::span<const ColumnSurface> sb = b.surfaces().Column(ix, iy);
  const auto same_surface = [](const ColumnSurface& p, const ColumnSurface& q) {
    return p.ground_z_m == q.ground_z_m && p.clearance_m == q.clearance_m &&
           p.tilt_rad == q.tilt_rad && p.plane_center_z_m == q.plane_center_z_m &&
           p.top_layer == q.top_layer && p.bottom_layer == q.bottom_layer && p.valid == q.valid;
  };
  if (!std::equal(sa.begin(), sa.end(), sb.begin(), sb.end(), same_surface)) return false;
  const TerrainFields::Parts fa = a.fields().ToParts();
  const TerrainFields::Parts fb = b.fields().ToParts();
  const std::int64_t c = ix + std::int64_t{a.grid().size.x()} * iy;
  const auto values = [c](const TerrainFields::Parts& f) {
    std::vector<std::int64_t> out;  // Each interval's first layer, then its values.
    for (std::uint32_t k = f.column_begin[c]; k < f.column_begin[c + 1]; ++k) {
      out.push_back(f.intervals[k].first_layer);
      for (std::uint32_t v = f.intervals[k].offset; v < f.intervals[k + 1].offset; ++v) {
        out.push_back(f.distance[v]);
        out.push_back(f.safety[v]);
      }
    }
    return out;
  };
  return values(fa) == values(fb);
}

// The smallest box of the columns where `edited` differs from `base` (same grid).
CellBox DifferingColumns(const TerrainModel& base, const TerrainModel& edited) {
  CellBox box;
  const GridGeometry& g = base.grid();
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      if (SameColumn(base, edited, ix, iy)) continue;
      const Eigen::Vector3i c(ix, iy, 0);
      box = box.empty() ? CellBox{c, c} : CellBox{box.min.cwiseMin(c), box.max.cwiseMax(c)};
    }
  }
  return box;
}

void ExpectSameGraph(const SurfaceGraph& patched, const SurfaceGraph& built) {
  ASSERT_EQ(patched.node_count(), built.node_count());
  EXPECT_EQ(patched.component_count(), built.component_count());
  EXPECT_EQ(patched.open_ground_clearance_m(), built.open_ground_clearance_m());
  EXPECT_EQ(patched.landmark_count(), built.landmark_count());
  int first_difference = -1;
  for (int k = 0; k < built.node_count() && first_difference < 0; ++k) {
    const SurfaceGraph::Node& a = patched.nodes()[k];
    const SurfaceGraph::Node& b = built.nodes()[k];
    const bool same = a.ix == b.ix && a.iy == b.iy && a.surface_index == b.surface_index &&
                      a.level == b.level && a.reference_z_m == b.reference_z_m &&
                      a.clearance_m == b.clearance_m &&
                      patched.component(k) == built.component(k) &&
                      patched.edge_distance(k) == built.edge_distance(k);
    if (!same) first_difference = k;
  }
  EXPECT_EQ(first_difference, -1) << "node " << first_difference << ": patched column ("
                                  << patched.nodes()[first_difference].ix << ", "
                                  << patched.nodes()[first_difference].iy << ") component "
                                  << patched.component(first_difference) << " rim distance "
                                  << patched.edge_distance(first_difference) << ", built ("
                                  << built.nodes()[first_difference].ix << ", "
                                  << built.nodes()[first_difference].iy << ") "
                                  << built.component(first_difference) << " "
                                  << built.edge_distance(first_difference);
  const std::span<const float> a = patched.landmark_distances();
  const std::span<const float> b = built.landmark_distances();
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end())) << "landmark distances";
  const GridGeometry& g = built.grid();
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      const SurfaceGraph::NodeRange p = patched.ColumnNodes(ix, iy);
      const SurfaceGraph::NodeRange q = built.ColumnNodes(ix, iy);
      ASSERT_TRUE(std::equal(p.begin(), p.end(), q.begin(), q.end()))
          << "column (" << ix << ", " << iy << ")";
    }
  }
}

TEST(SurfaceGraphPatch, AfterEachEditOfASequenceEqualsTheGraphBuiltOnTheEditedModel) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  Version version{test_util::Yard(), nullptr, {}};
  version.model = TerrainModel::Assess(version.cloud, config).value();
  SurfaceGraph graph = SurfaceGraph::Build(*version.model, Params()).value();
  const int components_before = graph.component_count();

  using Kind = MapEdit::Kind;
  const std::vector<MapEdit> edits{
      // A wall across the yard: its floor falls in two. (Every edit keeps within the cloud's
      // bounds, which would move the grid: that map is assessed afresh.)
      BoxEdit(Kind::kAddObstacle, {5.0, 0.0, 0.0}, {5.3, 6.0, 0.5}),
      // A hole in the floor beside the ramp.
      BoxEdit(Kind::kRemovePoints, {5.8, 0.2, -0.5}, {6.9, 1.4, 0.5}),
      // The wall taken down again: one floor.
      BoxEdit(Kind::kRemovePoints, {4.9, -0.5, 0.02}, {5.4, 6.5, 0.6}),
      // A pallet on the ramp's foot.
      BoxEdit(Kind::kAddObstacle, {7.2, 2.5, 0.0}, {8.0, 3.3, 0.5}),
  };
  std::vector<int> component_counts;
  // A graph refers to its model, which must outlive it: every version's is kept.
  std::vector<std::shared_ptr<const TerrainModel>> models{version.model};
  for (const MapEdit& edit : edits) {
    version = Edited(version, edit);
    models.push_back(version.model);
    Expected<SurfaceGraph> patched =
        SurfaceGraph::Patch(graph, *version.model, version.changed_columns);
    ASSERT_TRUE(patched) << patched.error().message;
    const SurfaceGraph built = SurfaceGraph::Build(*version.model, Params()).value();
    ExpectSameGraph(*patched, built);
    component_counts.push_back(built.component_count());
    graph = std::move(patched).value();  // The next edit patches the patched graph.
  }
  // The sequence did relabel: the wall split the floor, and taking it down joined it.
  EXPECT_GT(component_counts[0], components_before);
  EXPECT_LT(component_counts[2], component_counts[1]);
}

TEST(SurfaceGraphPatch, EqualsTheBuiltGraphWhenTheFloorUnderADeckAndTheDeckChange) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  Version version{GenerateTwoLevelRamp(5), nullptr, {}};
  version.model = TerrainModel::Assess(version.cloud, config).value();
  const SurfaceGraph base = SurfaceGraph::Build(*version.model, Params()).value();
  const Eigen::AlignedBox3d bounds = version.model->summary().cloud_bounds_m;
  const Eigen::Vector3d mid = bounds.center();
  // Blocks through every level at the middle of the scene, then one at its floor only.
  for (const MapEdit& edit :
       {BoxEdit(MapEdit::Kind::kAddObstacle, {mid.x() - 0.6, mid.y() - 0.6, bounds.min().z()},
                {mid.x() + 0.6, mid.y() + 0.6, bounds.max().z()}),
        BoxEdit(MapEdit::Kind::kRemovePoints, {mid.x() + 1.0, mid.y() - 1.0, bounds.min().z()},
                {mid.x() + 2.0, mid.y() + 1.0, bounds.min().z() + 0.5})}) {
    const Version next = Edited(version, edit);
    Expected<SurfaceGraph> patched = SurfaceGraph::Patch(base, *next.model, next.changed_columns);
    ASSERT_TRUE(patched) << patched.error().message;
    ExpectSameGraph(*patched, SurfaceGraph::Build(*next.model, Params()).value());
  }
}

// The columns ReassessRegion names are a bound, wide enough that the fields at its rim rarely
// change: patched with the very columns that differ, the graph still equals the built one
// (their neighbours' clearances and moves change too).
TEST(SurfaceGraphPatch, EqualsTheBuiltGraphGivenOnlyTheColumnsThatDiffer) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  Version version{test_util::Yard(), nullptr, {}};
  version.model = TerrainModel::Assess(version.cloud, config).value();
  const SurfaceGraph base = SurfaceGraph::Build(*version.model, Params()).value();
  for (const MapEdit& edit :
       {BoxEdit(MapEdit::Kind::kAddObstacle, {5.0, 2.0, 0.0}, {5.3, 2.4, 0.5}),
        BoxEdit(MapEdit::Kind::kRemovePoints, {5.8, 0.2, -0.5}, {6.9, 1.4, 0.5})}) {
    const Version next = Edited(version, edit);
    const CellBox differing = DifferingColumns(*version.model, *next.model);
    ASSERT_FALSE(differing.empty());
    EXPECT_LT(differing.CellCount(), next.changed_columns.CellCount());
    Expected<SurfaceGraph> patched = SurfaceGraph::Patch(base, *next.model, differing);
    ASSERT_TRUE(patched) << patched.error().message;
    ExpectSameGraph(*patched, SurfaceGraph::Build(*next.model, Params()).value());
  }
}

TEST(SurfaceGraphPatch, RefusesAGraphOfAnotherGrid) {
  const SurfaceGraph other = SurfaceGraph::Build(test_util::YardModel(), Params()).value();
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  const auto model = TerrainModel::Assess(test_util::Yard(), config).value();
  Expected<SurfaceGraph> patched = SurfaceGraph::Patch(other, *model, CellBox{});
  ASSERT_FALSE(patched);
  EXPECT_EQ(patched.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(patched.error().message.find("build the graph instead"), std::string::npos);
}

}  // namespace
}  // namespace strata
