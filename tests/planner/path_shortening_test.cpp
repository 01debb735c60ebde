#include "strata/planning/path_shortening.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata {
namespace {

std::shared_ptr<const TerrainModel> Assess(const PointCloud& cloud, double resolution_m = 0.1) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  auto model = TerrainModel::Assess(cloud, config);
  EXPECT_TRUE(model.ok()) << model.error().message;
  return model.ok() ? *model : nullptr;
}

bool AreNeighbors(const SurfaceGraph& graph, int a, int b) {
  bool found = false;
  graph.ForEachNeighbor(a, [&](int m) { found = found || m == b; });
  return found;
}

int Snap(const SurfaceGraph& graph, const Eigen::Vector3d& p) {
  auto s = SnapToSurface(graph, p, 1.0, ErrorCode::kStartOffGround);
  EXPECT_TRUE(s.ok()) << s.error().message;
  return s.ok() ? s->node : -1;
}

// A floor of 10 × 6 m with a block (a pillar) in the middle, 1.5 m high.
class PillarRoom : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    test_util::CloudBuilder cloud(0.05);
    cloud.Plate(0, 10, 0, 6, 0).Block(4.5, 5.5, 2.0, 4.0, 0.05, 1.5);
    model_ = new std::shared_ptr<const TerrainModel>(Assess(cloud.cloud()));
    auto graph = SurfaceGraph::Build(**model_, TraversabilityParams{});
    ASSERT_TRUE(graph.ok()) << graph.error().message;
    graph_ = new SurfaceGraph(*std::move(graph));
  }
  static void TearDownTestSuite() {
    delete graph_;
    delete model_;
  }
  const SurfaceGraph& graph() const { return *graph_; }

  // Every consecutive pair of nodes adjacent in the graph: the path is walkable as it is.
  void ExpectWalkable(const PathResult& path) const {
    ASSERT_EQ(path.nodes.size(), path.points_m.size());
    for (std::size_t k = 1; k < path.nodes.size(); ++k) {
      EXPECT_TRUE(AreNeighbors(graph(), path.nodes[k - 1], path.nodes[k])) << k;
    }
    double length = 0;
    for (std::size_t k = 1; k < path.points_m.size(); ++k) {
      length += (path.points_m[k] - path.points_m[k - 1]).norm();
    }
    EXPECT_NEAR(path.length_m, length, 1e-9);
  }

  static std::shared_ptr<const TerrainModel>* model_;
  static SurfaceGraph* graph_;
};
std::shared_ptr<const TerrainModel>* PillarRoom::model_ = nullptr;
SurfaceGraph* PillarRoom::graph_ = nullptr;

class OpenStretch : public PillarRoom, public ::testing::WithParamInterface<double> {};

// Also where the clearance margin exceeds what open ground leaves (the ground itself is an
// obstacle, about the reference height below): no path keeps that margin, so no line must.
TEST_P(OpenStretch, BecomesOneStraightLine) {
  SearchConfig search;
  search.clearance_margin_m = GetParam();
  // South of the pillar, well inside the floor's rim on both sides.
  const int a = Snap(graph(), {1.0, 0.8, 0.3}), b = Snap(graph(), {9.0, 1.2, 0.3});
  const auto path = SearchPath(graph(), a, b, search, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  const PathResult shortened = ShortenPath(graph(), *path, search);
  ExpectWalkable(shortened);
  EXPECT_EQ(shortened.nodes.front(), a);
  EXPECT_EQ(shortened.nodes.back(), b);
  const double straight = (graph().position(b) - graph().position(a)).norm();
  EXPECT_GT(path->length_m, straight + 0.05);  // The grid's path has a kink.
  EXPECT_NEAR(shortened.length_m, straight, 1e-6);
  // Every point lies on the line from a to b.
  const Eigen::Vector2d direction =
      (graph().position(b) - graph().position(a)).head<2>().normalized();
  for (const Eigen::Vector3d& p : shortened.points_m) {
    const Eigen::Vector2d offset = (p - graph().position(a)).head<2>();
    EXPECT_NEAR(offset.x() * direction.y() - offset.y() * direction.x(), 0, 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(ClearanceMargins, OpenStretch,
                         ::testing::Values(SearchConfig{}.clearance_margin_m, 1.0));

// An 8-connected path across a long open floor runs diagonally and straight, with a bend
// between. Where the path runs nearly straight, a line may replace more than max_segment_m
// of it, and the bend goes; with windows of max_segment_m only, it stays (rounded).
TEST(PathShortening, ALongNearlyStraightPathBecomesOneLine) {
  test_util::CloudBuilder cloud(0.1);
  cloud.Plate(0, 32, 0, 12, 0);
  const auto model = Assess(cloud.cloud(), 0.2);
  ASSERT_NE(model, nullptr);
  auto graph = SurfaceGraph::Build(*model, TraversabilityParams{});
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  SearchConfig search;
  search.line_bias = 0;  // The grid's own path: a diagonal run and a straight one.
  const int a = Snap(*graph, {2.0, 2.0, 0.3}), b = Snap(*graph, {30.0, 10.0, 0.3});
  const auto path = SearchPath(*graph, a, b, search, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  const double straight = (graph->position(b) - graph->position(a)).norm();
  ASSERT_GT(path->length_m, ShorteningConfig{}.max_segment_m);
  ASSERT_GT(path->length_m, straight + 1.0);

  const PathResult shortened = ShortenPath(*graph, *path, search);
  EXPECT_NEAR(shortened.length_m, straight, 1e-6);
  ShorteningConfig windows_only;
  windows_only.max_straight_segment_m = windows_only.max_segment_m;
  const PathResult rounded = ShortenPath(*graph, *path, search, windows_only);
  EXPECT_GT(rounded.length_m, straight + 0.05);
}

// On gently rolling open ground the obstacle distance at the reference point (the ground's
// own, below it) varies by millimetres from column to column. With a clearance margin no path
// keeps, capped at what open ground leaves, a line across it must not fail at a node a
// millimetre under the cap: the path becomes one straight line.
TEST(PathShortening, AcrossRollingOpenGroundTheLineIsStraight) {
  test_util::CloudBuilder cloud(0.05);
  cloud.Surface(0, 12, 0, 8,
                [](double x, double y) { return 0.015 * std::sin(2.1 * x) * std::cos(1.7 * y); });
  const auto model = Assess(cloud.cloud(), 0.2);
  ASSERT_NE(model, nullptr);
  auto graph = SurfaceGraph::Build(*model, TraversabilityParams{});
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  SearchConfig search;
  search.clearance_margin_m = 1.0;  // No path keeps it: the cap applies.
  int lines = 0, under_cap = 0;
  for (double y0 = 1.5; y0 <= 6.5; y0 += 1.0) {
    const int a = Snap(*graph, {1.5, y0, 0.3}), b = Snap(*graph, {10.5, 8.0 - y0, 0.3});
    const auto path = SearchPath(*graph, a, b, search, {});
    ASSERT_TRUE(path.ok()) << path.error().message;
    const double straight = (graph->position(b) - graph->position(a)).norm();
    ASSERT_GT(path->length_m, straight + 0.05) << y0;  // The grid's path has a kink.
    const PathResult shortened = ShortenPath(*graph, *path, search);
    EXPECT_NEAR(shortened.length_m, straight, 0.01 * straight) << y0;
    lines += std::abs(shortened.length_m - straight) < 1e-3 * straight;
    for (const int m : shortened.nodes) {
      under_cap += graph->clearance(m) < graph->open_ground_clearance_m();
    }
  }
  EXPECT_EQ(lines, 6);
  EXPECT_GT(under_cap, 0);  // The lines did cross columns under the percentile.
}

// Round a pillar: the lines cost no more than the searched path in the search's own terms
// (length weighted by nearness to the rim and obstacles), so they shortcut the search's
// detour only where the cost allows; they keep a cell and a half from the rim and the
// search's distance from obstacles (or their ends' if less), and never touch the pillar.
TEST_F(PillarRoom, AroundAPillarTheLinesCostNoMoreThanTheSearchsPath) {
  const SearchConfig search;
  const int a = Snap(graph(), {3.0, 3.0, 0.3}), b = Snap(graph(), {7.0, 3.0, 0.3});
  const auto path = SearchPath(graph(), a, b, search, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  const PathResult shortened = ShortenPath(graph(), *path, search);
  ExpectWalkable(shortened);
  EXPECT_LT(shortened.length_m, path->length_m);
  EXPECT_LE(shortened.cost, path->cost + 1e-9);
  const double r = graph().grid().resolution_m;
  const double end_rim = std::min(graph().edge_distance(a), graph().edge_distance(b));
  const double end_clearance = std::min(graph().clearance(a), graph().clearance(b));
  // ShortenPath caps the margin 1 cm under the open-ground clearance (open ground's spread).
  const double clearance_floor = std::min(
      {end_clearance, search.clearance_margin_m, graph().open_ground_clearance_m() - 0.01});
  for (const int m : shortened.nodes) {
    EXPECT_GE(graph().edge_distance(m), std::min(end_rim, 1.5 * r) - 1e-6)
        << graph().position(m).transpose();
    EXPECT_GE(graph().clearance(m), clearance_floor - 1e-6) << graph().position(m).transpose();
  }
  for (const Eigen::Vector3d& p : shortened.points_m) {
    const bool in_pillar = p.x() > 4.4 && p.x() < 5.6 && p.y() > 1.9 && p.y() < 4.1;
    EXPECT_FALSE(in_pillar) << p.transpose();
  }
  // Round the pillar there are two corners: the shortened path has few vertices, not the
  // grid's staircase.
  int turns = 0;
  for (std::size_t k = 1; k + 1 < shortened.points_m.size(); ++k) {
    const Eigen::Vector2d in = (shortened.points_m[k] - shortened.points_m[k - 1]).head<2>();
    const Eigen::Vector2d out = (shortened.points_m[k + 1] - shortened.points_m[k]).head<2>();
    if (in.norm() > 1e-9 && out.norm() > 1e-9 && in.normalized().dot(out.normalized()) < 0.999) {
      ++turns;
    }
  }
  EXPECT_LE(turns, 4);
}

TEST_F(PillarRoom, BlockedNodesAreNeverCrossed) {
  const SearchConfig search;
  const int a = Snap(graph(), {1.0, 1.0, 0.3}), b = Snap(graph(), {9.0, 1.0, 0.3});
  // A keep-out square the search went round: x in [4.5, 5.5], y < 1.5.
  const auto blocked = [&](int m) {
    const Eigen::Vector3d p = graph().position(m);
    return p.x() > 4.5 && p.x() < 5.5 && p.y() < 1.5;
  };
  const auto path = SearchPath(graph(), a, b, search, {}, nullptr, blocked);
  ASSERT_TRUE(path.ok()) << path.error().message;
  const PathResult shortened = ShortenPath(graph(), *path, search, {}, blocked);
  ExpectWalkable(shortened);
  for (const int m : shortened.nodes) EXPECT_FALSE(blocked(m)) << graph().position(m).transpose();
  // Without the zone, the line goes straight through it.
  const PathResult open = ShortenPath(graph(), *path, search);
  EXPECT_LT(open.length_m, shortened.length_m);
}

TEST_F(PillarRoom, WalkStraightFailsAcrossThePillarAndSucceedsBesideIt) {
  const auto any = [](int) { return true; };
  const int west = Snap(graph(), {3.5, 3.0, 0.3}), east = Snap(graph(), {6.5, 3.0, 0.3});
  EXPECT_TRUE(WalkStraight(graph(), west, east, any).empty());
  const int south_west = Snap(graph(), {3.5, 1.0, 0.3}),
            south_east = Snap(graph(), {6.5, 1.3, 0.3});
  const std::vector<int> walk = WalkStraight(graph(), south_west, south_east, any);
  ASSERT_FALSE(walk.empty());
  EXPECT_EQ(walk.front(), south_west);
  EXPECT_EQ(walk.back(), south_east);
  // Column by column: each step to an edge-adjacent column, 30 + 3 steps.
  for (std::size_t k = 1; k < walk.size(); ++k) {
    const Eigen::Vector2i step = graph().column(walk[k]) - graph().column(walk[k - 1]);
    EXPECT_EQ(step.cwiseAbs().sum(), 1) << k;
  }
  EXPECT_EQ(walk.size(), 34u);
}

TEST(PathShortening, AClimbOntoADeckStaysWalkableAndNoLonger) {
  // Two levels: from the floor up the ramp onto the deck, over the pillars under it.
  const auto model = Assess(GenerateTwoLevelRamp(5));
  ASSERT_NE(model, nullptr);
  auto graph = SurfaceGraph::Build(*model, TraversabilityParams{});
  ASSERT_TRUE(graph.ok());
  const TwoLevelRampLayout layout = GetTwoLevelRampLayout();
  const SearchConfig search;
  const int a = Snap(*graph, layout.start_example_m);
  const int b = Snap(*graph, layout.goal_example_m);
  const auto path = SearchPath(*graph, a, b, search, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  const PathResult shortened = ShortenPath(*graph, *path, search);
  EXPECT_LE(shortened.length_m, path->length_m + 1e-9);
  for (std::size_t k = 1; k < shortened.nodes.size(); ++k) {
    EXPECT_TRUE(AreNeighbors(*graph, shortened.nodes[k - 1], shortened.nodes[k])) << k;
  }
  EXPECT_EQ(graph->level(shortened.nodes.front()), graph->level(a));
  EXPECT_EQ(shortened.nodes.back(), b);
}

}  // namespace
}  // namespace strata
