#include "strata/planning/path_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <queue>
#include <random>
#include <span>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/scenes/basic_scenes.hpp"
#include "strata/scenes/scenes.hpp"
#include "test_util/terrain_queries.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const TerrainModel> AssessScene(const PointCloud& cloud) {
  AssessmentConfig config;
  config.grid.resolution_m = 0.1;
  auto model = TerrainModel::Assess(cloud, config);
  EXPECT_TRUE(model.ok()) << model.error().message;
  return model.ok() ? *model : nullptr;
}

// Least costs from the sources (the finite entries of `dist`) over the graph's moves, each
// costing step(from, to), by Dijkstra with a heap: the reference for the searches under test.
template <typename Cost, typename Step>
std::vector<Cost> LeastCosts(const SurfaceGraph& graph, std::vector<Cost> dist, const Step& step) {
  using Item = std::pair<Cost, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (int v = 0; v < graph.node_count(); ++v) {
    if (dist[v] < std::numeric_limits<Cost>::infinity()) queue.push({dist[v], v});
  }
  while (!queue.empty()) {
    // Not a structured binding: the lambda below captures them (clang 14 cannot).
    const Cost d = queue.top().first;
    const int v = queue.top().second;
    queue.pop();
    if (d > dist[v]) continue;
    graph.ForEachNeighbor(v, [&](int m) {
      const Cost next = d + step(v, m);
      if (next < dist[m]) {
        dist[m] = next;
        queue.push({next, m});
      }
    });
  }
  return dist;
}

// Plain Dijkstra over the same graph and edge costs: the reference for A*.
std::vector<double> Dijkstra(const SurfaceGraph& graph, int source, const SearchConfig& config) {
  std::vector<double> dist(graph.node_count(), std::numeric_limits<double>::infinity());
  dist[source] = 0;
  return LeastCosts(graph, std::move(dist),
                    [&](int a, int b) { return EdgeCost(graph, a, b, config); });
}

bool AreNeighbors(const SurfaceGraph& graph, int a, int b) {
  bool found = false;
  graph.ForEachNeighbor(a, [&](int m) { found = found || m == b; });
  return found;
}

class TwoLevel : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = new std::shared_ptr<const TerrainModel>(AssessScene(GenerateTwoLevelRamp(5)));
    ASSERT_NE(*model_, nullptr);
    auto graph = SurfaceGraph::Build(**model_, TraversabilityParams{});
    ASSERT_TRUE(graph.ok()) << graph.error().message;
    graph_ = new SurfaceGraph(*std::move(graph));
  }
  static void TearDownTestSuite() {
    delete graph_;
    delete model_;
  }
  const TerrainModel& model() const { return **model_; }
  const SurfaceGraph& graph() const { return *graph_; }
  int Snap(const Eigen::Vector3d& p) const {
    auto s = SnapToSurface(graph(), p, 1.0, ErrorCode::kStartOffGround);
    EXPECT_TRUE(s.ok()) << s.error().message;
    return s.ok() ? s->node : -1;
  }
  // The nodes of `node`'s connected component.
  std::vector<int> ComponentOf(int node) const {
    std::vector<int> component;
    for (int v = 0; v < graph().node_count(); ++v) {
      if (graph().component(v) == graph().component(node)) component.push_back(v);
    }
    return component;
  }

  static std::shared_ptr<const TerrainModel>* model_;
  static SurfaceGraph* graph_;
  TwoLevelRampLayout layout_ = GetTwoLevelRampLayout();
  TraversabilityParams params_;
};
std::shared_ptr<const TerrainModel>* TwoLevel::model_ = nullptr;
SurfaceGraph* TwoLevel::graph_ = nullptr;

TEST_F(TwoLevel, BuildRejectsBadParamsNamingTheField) {
  TraversabilityParams p;
  p.max_tilt_rad = model().config().ground.max_tilt_rad + 0.1;
  auto g = SurfaceGraph::Build(model(), p);
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(g.error().message, HasSubstr("max_tilt_rad"));
  EXPECT_THAT(g.error().message, HasSubstr("ground.max_tilt_rad"));
  p = {};
  p.body_height_m = -1;
  g = SurfaceGraph::Build(model(), p);
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.error().message, HasSubstr("body_height_m"));
  SearchConfig c;
  c.clearance_margin_m = 0;
  ASSERT_FALSE(c.Validate().ok());
  EXPECT_THAT(c.Validate().error().message, HasSubstr("clearance_margin_m"));
}

// The graph is the one definition of where the robot stands: its nodes keep the promises of
// surface_graph.hpp (valid ground, tilt and clearance within the params, the reference point
// at the reference height above the ground, inside the grid).
TEST_F(TwoLevel, EveryNodeStandsOnAllowedGroundAndEdgesRespectTheStep) {
  ASSERT_GT(graph().node_count(), 1000);
  for (int v = 0; v < graph().node_count(); v += 7) {
    const ColumnSurface& surface = graph().surface(v);
    EXPECT_TRUE(surface.valid) << v;
    EXPECT_LE(surface.tilt_rad, params_.max_tilt_rad) << v;
    EXPECT_GE(surface.clearance_m, params_.body_height_m) << v;
    EXPECT_NEAR(graph().position(v).z(), surface.ground_z_m + params_.reference_height_m, 1e-4)
        << v;
    EXPECT_TRUE(model().grid().Contains(graph().cell(v))) << v;
    graph().ForEachNeighbor(v, [&](int m) {
      EXPECT_LE(std::abs(graph().ground_z(m) - graph().ground_z(v)), params_.max_step_m + 1e-6);
      EXPECT_LE((graph().cell(m) - graph().cell(v)).cwiseAbs().maxCoeff(), 1);
      EXPECT_TRUE(AreNeighbors(graph(), m, v));  // Undirected.
      EXPECT_EQ(graph().component(m), graph().component(v));
    });
  }
}

TEST_F(TwoLevel, MovesNearTheRimCostMoreAndInteriorMovesCostTheirLength) {
  SearchConfig plain;
  plain.rim_weight = 0;
  const SearchConfig rim_aware;  // Defaults: rim_weight 1, rim_margin_m 0.4.
  int rim_pairs = 0;
  int interior_pairs = 0;
  for (int a = 0; a < graph().node_count(); ++a) {
    graph().ForEachNeighbor(a, [&](int b) {
      const double length = (graph().position(a) - graph().position(b)).norm();
      const double e = std::min(graph().edge_distance(a), graph().edge_distance(b));
      const double c = std::min(graph().clearance(a), graph().clearance(b));
      const double with = EdgeCost(graph(), a, b, rim_aware);
      const double without = EdgeCost(graph(), a, b, plain);
      ASSERT_GE(without, length - 1e-12);
      if (e < rim_aware.rim_margin_m) {
        ++rim_pairs;
        EXPECT_NEAR(with - without, length * (rim_aware.rim_margin_m - e) / rim_aware.rim_margin_m,
                    1e-9);
      } else if (c >= rim_aware.clearance_margin_m) {
        ++interior_pairs;
        EXPECT_NEAR(with, length, 1e-12);
      }
    });
  }
  EXPECT_GT(rim_pairs, 100);
  EXPECT_GT(interior_pairs, 1000);
}

TEST_F(TwoLevel, SnapPicksTheLevelTheHeightPointsAt) {
  Eigen::Vector3d p = layout_.start_example_m;
  p.z() = layout_.floor_z_m + 0.5;
  auto s = SnapToSurface(graph(), p, 1.0, ErrorCode::kStartOffGround);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->level, 0);
  EXPECT_NEAR(s->position_m.z(), layout_.floor_z_m + params_.reference_height_m, 0.03);
  // p is in the floor's air space, so only the horizontal offset counts.
  EXPECT_NEAR(s->distance_m, (s->position_m - p).head<2>().norm(), 1e-9);

  // A z up to 2.5 m above the open floor still points at it; 20 m above, nothing is within
  // the tolerance; a point below the floor is that far off it.
  p.z() = layout_.floor_z_m + 2.4;
  s = SnapToSurface(graph(), p, 1.0, ErrorCode::kStartOffGround);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->level, 0);
  p.z() = layout_.floor_z_m + 20.0;
  EXPECT_EQ(SnapToSurface(graph(), p, 1.0, ErrorCode::kStartOffGround).error().code,
            ErrorCode::kStartOffGround);
  p.z() = layout_.floor_z_m - 2.0;
  EXPECT_EQ(SnapToSurface(graph(), p, 1.0, ErrorCode::kStartOffGround).error().code,
            ErrorCode::kStartOffGround);
  p = layout_.start_example_m;

  p = layout_.goal_example_m;
  p.z() = layout_.deck_z_m + 0.5;
  s = SnapToSurface(graph(), p, 1.0, ErrorCode::kGoalOffGround);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->level, 1);
  EXPECT_NEAR(s->position_m.z(), layout_.deck_z_m + params_.reference_height_m, 0.03);

  p.z() = 1.0;  // Under the deck, between the levels (0.7 m above the floor's reference).
  s = SnapToSurface(graph(), p, 1.0, ErrorCode::kGoalOffGround);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->level, 0);
  EXPECT_NEAR(s->position_m.z(), layout_.floor_z_m + params_.reference_height_m, 0.03);
}

TEST_F(TwoLevel, SnapFarOutsideNamesTheNearestValidPoint) {
  const Eigen::Vector3d p(layout_.room_x_max_m + 5.0, 3.0, 0.0);
  auto s = SnapToSurface(graph(), p, 1.0, ErrorCode::kGoalOffGround);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGoalOffGround);
  EXPECT_THAT(s.error().message, HasSubstr("goal (25.00, 3.00, 0.00) m"));
  EXPECT_THAT(s.error().message, HasSubstr("within 1.00 m"));
  EXPECT_THAT(s.error().message, HasSubstr("the nearest is ("));

  // High above the open deck: no level's air space reaches 10 m up.
  const Eigen::Vector3d above_deck(layout_.goal_example_m.x(), layout_.goal_example_m.y(),
                                   layout_.deck_z_m + 10.0);
  s = SnapToSurface(graph(), above_deck, 1.0, ErrorCode::kGoalOffGround);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGoalOffGround);

  s = SnapToSurface(graph(), Eigen::Vector3d(std::nan(""), 1, 1), 1.0, ErrorCode::kStartOffGround);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
}

TEST_F(TwoLevel, AStarMatchesDijkstra) {
  const int start = Snap(layout_.start_example_m);
  ASSERT_GE(start, 0);
  const std::vector<int> component = ComponentOf(start);
  std::mt19937 rng(42);
  // Plain A* (w = 1) is optimal; weighted A* (the default w) costs at most w times that, and
  // with the default line bias at most line_bias times the largest distance of a node from
  // the start-goal line more (bounded here by the grid's diagonal).
  SearchConfig plain;
  plain.heuristic_weight = 1.0;
  plain.line_bias = 0;
  SearchConfig weighted;
  weighted.line_bias = 0;
  ASSERT_GT(weighted.heuristic_weight, 1.0);
  const SearchConfig biased;
  ASSERT_GT(biased.line_bias, 0.0);
  const double diagonal =
      graph().grid().size.head<2>().cast<double>().norm() * graph().grid().resolution_m;
  // Plain A* from a to b under `config` into *path; its cost must be `cheapest`.
  const auto plain_search = [&](const SearchConfig& config, int a, int b, double cheapest,
                                PathResult* path) {
    auto found = SearchPath(graph(), a, b, config, {});
    ASSERT_TRUE(found.ok()) << found.error().message;
    EXPECT_NEAR(found->cost, cheapest, 1e-9 * std::max(1.0, cheapest));
    *path = std::move(found).value();
  };
  for (int trial = 0; trial < 6; ++trial) {
    const int a = component[rng() % component.size()];
    const std::vector<double> dist = Dijkstra(graph(), a, plain);
    for (int k = 0; k < 4; ++k) {
      const int b = component[rng() % component.size()];
      auto fast = SearchPath(graph(), a, b, weighted, {});
      ASSERT_TRUE(fast.ok()) << fast.error().message;
      EXPECT_GE(fast->cost, dist[b] - 1e-9 * std::max(1.0, dist[b]));
      EXPECT_LE(fast->cost, weighted.heuristic_weight * dist[b] + 1e-9);
      auto leaning = SearchPath(graph(), a, b, biased, {});
      ASSERT_TRUE(leaning.ok()) << leaning.error().message;
      EXPECT_GE(leaning->cost, dist[b] - 1e-9 * std::max(1.0, dist[b]));
      EXPECT_LE(leaning->cost,
                biased.heuristic_weight * dist[b] + biased.line_bias * diagonal + 1e-9);
      PathResult path;
      ASSERT_NO_FATAL_FAILURE(plain_search(plain, a, b, dist[b], &path));
      double cost = 0;
      for (std::size_t i = 1; i < path.nodes.size(); ++i) {
        cost += EdgeCost(graph(), path.nodes[i - 1], path.nodes[i], plain);
      }
      EXPECT_NEAR(cost, path.cost, 1e-9 * std::max(1.0, cost));
      EXPECT_GE(path.cost, path.length_m - 1e-9);
    }
  }
  // Plain A* stays optimal under move costs stiffer than the landmarks' (their bound still
  // holds) and softer ones (the landmarks are left out).
  SearchConfig stiffer = plain, softer = plain;
  stiffer.rim_weight = 3;
  softer.clearance_weight = 0;
  for (const SearchConfig& config : {stiffer, softer}) {
    const int a = component[rng() % component.size()];
    const std::vector<double> dist = Dijkstra(graph(), a, config);
    for (int k = 0; k < 4; ++k) {
      const int b = component[rng() % component.size()];
      PathResult path;
      ASSERT_NO_FATAL_FAILURE(plain_search(config, a, b, dist[b], &path));
    }
  }
}

// The graph's one-to-all searches (a bucket queue, nodes of a bucket in any order) end where
// Dijkstra's with a heap does, bit for bit: the landmarks' distances from a float search over
// the moves' float costs, and the rim distances from one over the steps r and r√2.
TEST_F(TwoLevel, LandmarkAndRimDistancesAreAHeapDijkstrasBitForBit) {
  const SurfaceGraph& g = graph();
  const int n = g.node_count();
  const int count = g.landmark_count();
  ASSERT_GT(count, 0);
  const MoveCostTerms terms;
  const auto move_cost = [&](int a, int b) { return static_cast<float>(g.MoveCost(a, b, terms)); };
  const std::span<const float> table = g.landmark_distances();
  for (int k = 0; k < count; ++k) {
    std::vector<float> from(n, std::numeric_limits<float>::infinity());
    for (int v = 0; v < n; ++v) {
      if (table[static_cast<std::size_t>(v) * count + k] == 0) from[v] = 0;  // The landmark.
    }
    const std::vector<float> expected = LeastCosts(g, std::move(from), move_cost);
    int differing = 0;
    for (int v = 0; v < n; ++v)
      differing += expected[v] != table[static_cast<std::size_t>(v) * count + k];
    EXPECT_EQ(differing, 0) << "landmark " << k;
  }
  const double r = g.grid().resolution_m;
  const auto cap = static_cast<float>(SurfaceGraph::EdgeDistanceCap(r));
  std::vector<float> rim(n, std::numeric_limits<float>::infinity());
  for (int v = 0; v < n; ++v) {
    int neighbours = 0;
    g.ForEachNeighbor(v, [&](int) { ++neighbours; });
    if (neighbours < 8) rim[v] = static_cast<float>(0.5 * r);
  }
  const auto step = [&](int a, int b) {
    const bool diagonal = g.nodes()[a].ix != g.nodes()[b].ix && g.nodes()[a].iy != g.nodes()[b].iy;
    return static_cast<float>(diagonal ? std::sqrt(2.0) * r : r);
  };
  const std::vector<float> expected = LeastCosts(g, std::move(rim), step);
  int differing = 0;
  for (int v = 0; v < n; ++v) differing += std::min(expected[v], cap) != g.edge_distances()[v];
  EXPECT_EQ(differing, 0);
}

TEST_F(TwoLevel, LandmarkBoundsNeverExceedTheCheapestCostAndKnowTheRamp) {
  ASSERT_GT(graph().landmark_count(), 0);
  const int start = Snap(layout_.start_example_m);
  ASSERT_GE(start, 0);
  const SearchConfig defaults;  // The terms the landmarks measure with.
  SearchConfig stiffer;         // Every move costs at least as much: still a bound.
  stiffer.rim_weight = 3;
  stiffer.clearance_margin_m = 0.3;
  const std::vector<double> cheapest = Dijkstra(graph(), start, defaults);
  const std::vector<double> cheapest_stiffer = Dijkstra(graph(), start, stiffer);
  int tighter = 0, pairs = 0, elsewhere = 0;
  for (int v = 0; v < graph().node_count(); v += 13) {
    if (!std::isfinite(cheapest[v])) {
      // Another component (a box's top): the landmarks measured nothing there.
      ++elsewhere;
      EXPECT_EQ(graph().LandmarkBound(start, v, defaults), 0.0);
      EXPECT_EQ(graph().LandmarkBound(v, start, defaults), 0.0);
      continue;
    }
    ++pairs;
    const double straight = (graph().position(v) - graph().position(start)).norm();
    const double bound = graph().LandmarkBound(start, v, defaults);
    EXPECT_LE(bound, cheapest[v] + 1e-9) << graph().position(v).transpose();
    EXPECT_LE(graph().LandmarkBound(start, v, stiffer), cheapest_stiffer[v] + 1e-9);
    tighter += bound > straight + 0.5;
  }
  // The deck lies above the floor: its straight line ignores the ramp, the landmarks do not.
  EXPECT_GT(tighter, pairs / 10) << tighter << " of " << pairs;
  EXPECT_GT(elsewhere, 0);
  const int deck = Snap(layout_.goal_example_m);
  EXPECT_GT(graph().LandmarkBound(start, deck, defaults),
            (graph().position(deck) - graph().position(start)).norm() + 1.0);
  // Under terms that make some move cheaper the landmarks' costs are no bound: none is given.
  SearchConfig softer;
  softer.rim_weight = 0;
  EXPECT_EQ(graph().LandmarkBound(start, deck, softer), 0.0);
}

TEST_F(TwoLevel, ReturnsThePathFromStartToGoalWhicheverEndItSearchesFrom) {
  const int start = Snap(layout_.start_example_m);
  ASSERT_GE(start, 0);
  const std::vector<int> component = ComponentOf(start);
  const SearchConfig config;
  std::mt19937 rng(7);
  int backward = 0, forward = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int a = component[rng() % component.size()];
    const int b = component[rng() % component.size()];
    const bool from_b = graph().ShouldSearchBackward(a, b, config);
    (from_b ? backward : forward) += 1;
    auto path = SearchPath(graph(), a, b, config, {});
    ASSERT_TRUE(path.ok()) << path.error().message;
    ASSERT_FALSE(path->nodes.empty());
    EXPECT_EQ(path->nodes.front(), a);
    EXPECT_EQ(path->nodes.back(), b);
    ASSERT_EQ(path->points_m.size(), path->nodes.size());
    double cost = 0;
    for (std::size_t i = 1; i < path->nodes.size(); ++i) {
      ASSERT_TRUE(AreNeighbors(graph(), path->nodes[i - 1], path->nodes[i]));
      EXPECT_EQ(path->points_m[i], graph().position(path->nodes[i]));
      cost += EdgeCost(graph(), path->nodes[i - 1], path->nodes[i], config);
    }
    EXPECT_NEAR(cost, path->cost, 1e-9 * std::max(1.0, cost));
    // Asked the other way round, the search starts from the same end (the landmarks' choice
    // is antisymmetric): the same search, its path reversed.
    if (from_b != graph().ShouldSearchBackward(b, a, config)) {
      auto reverse = SearchPath(graph(), b, a, config, {});
      ASSERT_TRUE(reverse.ok()) << reverse.error().message;
      EXPECT_THAT(reverse->nodes,
                  ::testing::ElementsAreArray(path->nodes.rbegin(), path->nodes.rend()));
      EXPECT_EQ(reverse->expansions, path->expansions);
    }
  }
  EXPECT_GT(backward, 0);  // Both ways were taken.
  EXPECT_GT(forward, 0);
}

TEST(MoveCostTerms, CostsAtLeastComparesEveryWeightAndMargin) {
  const MoveCostTerms defaults;
  EXPECT_TRUE(defaults.CostsAtLeast(defaults));
  for (double MoveCostTerms::*field :
       {&MoveCostTerms::clearance_weight, &MoveCostTerms::clearance_margin_m,
        &MoveCostTerms::rim_weight, &MoveCostTerms::rim_margin_m}) {
    MoveCostTerms more = defaults, less = defaults;
    more.*field *= 1.5;
    less.*field *= 0.5;
    EXPECT_TRUE(more.CostsAtLeast(defaults));
    EXPECT_FALSE(less.CostsAtLeast(defaults));
    EXPECT_FALSE(defaults.CostsAtLeast(more));
  }
}

TEST_F(TwoLevel, FloorToDeckClimbsTheRampOnValidGround) {
  const int start = Snap(layout_.start_example_m);
  const int goal = Snap(layout_.goal_example_m + Eigen::Vector3d(0, 0, 0.3));
  ASSERT_GE(start, 0);
  ASSERT_GE(goal, 0);
  ASSERT_EQ(graph().level(goal), 1);
  auto path = SearchPath(graph(), start, goal, SearchConfig{}, [] { return false; });
  ASSERT_TRUE(path.ok()) << path.error().message;
  const auto& pts = path->points_m;
  ASSERT_GE(pts.size(), 2u);
  EXPECT_EQ(pts.front(), graph().position(start));
  EXPECT_EQ(pts.back(), graph().position(goal));
  EXPECT_GT(path->expansions, 0);

  double last_ramp_z = -1e9;
  int ramp_points = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (i > 0) EXPECT_TRUE(AreNeighbors(graph(), path->nodes[i - 1], path->nodes[i])) << i;
    const auto ground = test_util::GroundHeightBelow(model(), pts[i]);
    ASSERT_TRUE(ground.has_value()) << i;
    EXPECT_NEAR(*ground, pts[i].z() - params_.reference_height_m, 1e-4) << i;
    const ColumnSurface* s = test_util::SurfaceBelow(model(), pts[i]);
    ASSERT_NE(s, nullptr);
    EXPECT_GE(s->clearance_m, params_.body_height_m) << i;
    const bool over_ramp = pts[i].x() > layout_.ramp_x_min_m + 0.2 &&
                           pts[i].x() < layout_.ramp_x_max_m - 0.2 &&
                           pts[i].y() > layout_.ramp_y_min_m && pts[i].y() < layout_.ramp_y_max_m;
    const bool between_levels =
        *ground > layout_.floor_z_m + 0.3 && *ground < layout_.deck_z_m - 0.3;
    if (between_levels) {
      // Columns straddling the ramp's sides may hold its edge.
      const bool near_ramp =
          pts[i].x() > layout_.ramp_x_min_m - 0.15 && pts[i].x() < layout_.ramp_x_max_m + 0.15 &&
          pts[i].y() > layout_.ramp_y_min_m - 0.15 && pts[i].y() < layout_.ramp_y_max_m + 0.15;
      EXPECT_TRUE(near_ramp) << "point " << i << " " << pts[i].transpose()
                             << " between the levels but off the ramp";
    }
    if (over_ramp && between_levels) {
      ++ramp_points;
      EXPECT_GE(pts[i].z(), last_ramp_z - 0.05) << i;  // Rises monotonically, up to noise.
      last_ramp_z = pts[i].z();
    }
  }
  EXPECT_GT(ramp_points, 10);
}

TEST_F(TwoLevel, CancelAndBudgetAreNamed) {
  const int start = Snap(layout_.start_example_m);
  const int goal = Snap(layout_.goal_example_m + Eigen::Vector3d(0, 0, 0.3));
  ASSERT_GE(start, 0);
  ASSERT_GE(goal, 0);
  auto r = SearchPath(graph(), start, goal, SearchConfig{}, [] { return true; });
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kCancelled);

  SearchConfig config;
  config.max_expansions = 10;
  SearchStats stats;
  r = SearchPath(graph(), start, goal, config, {}, &stats);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kSearchBudgetExhausted);
  EXPECT_THAT(r.error().message, HasSubstr("10 expansions"));
  EXPECT_EQ(stats.expansions, 10);
}

TEST_F(TwoLevel, TooSteepARampMakesTheDeckUnreachableWithoutSearching) {
  TraversabilityParams p;
  p.max_tilt_rad = layout_.ramp_slope_rad * 0.6;  // The ramp is steeper than the robot may go.
  auto g = SurfaceGraph::Build(model(), p);
  ASSERT_TRUE(g.ok()) << g.error().message;
  auto start = SnapToSurface(*g, layout_.start_example_m, 1.0, ErrorCode::kStartOffGround);
  auto goal = SnapToSurface(*g, layout_.goal_example_m + Eigen::Vector3d(0, 0, 0.3), 1.0,
                            ErrorCode::kGoalOffGround);
  ASSERT_TRUE(start.ok()) << start.error().message;
  ASSERT_TRUE(goal.ok()) << goal.error().message;
  int stop_calls = 0;
  SearchStats stats;
  stats.expansions = -1;
  auto r = SearchPath(
      *g, start->node, goal->node, SearchConfig{}, [&] { return ++stop_calls < 0; }, &stats);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kGoalUnreachable);
  EXPECT_THAT(r.error().message, HasSubstr("goal ("));
  EXPECT_THAT(r.error().message, HasSubstr("start ("));
  EXPECT_EQ(stats.expansions, 0);
  EXPECT_EQ(stop_calls, 0);
}

TEST(StairsRampRoom, FloorToLandingTakesTheRampNotTheStairs) {
  const auto model = AssessScene(GenerateStairsRampRoom(3, 0.05));
  ASSERT_NE(model, nullptr);
  const StairsRampLayout L = GetStairsRampLayout();
  TraversabilityParams params;
  params.max_step_m = 0.1;  // Below the stairs' 0.15 m risers.
  auto graph = SurfaceGraph::Build(*model, params);
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  const double stairs_x = 0.5 * (L.stairs_x_min_m + L.stairs_x_max_m);
  // In front of the stairs, and on the landing right above them: the straight line is the
  // stairs, whose 0.15 m risers exceed max_step_m.
  auto start = SnapToSurface(*graph, {stairs_x, L.stairs_y_min_m - 1.0, 0.0}, 0.5,
                             ErrorCode::kStartOffGround);
  auto goal = SnapToSurface(
      *graph, {stairs_x, 0.5 * (L.landing_y_min_m + L.room_y_max_m), L.landing_z_m + 0.2}, 0.5,
      ErrorCode::kGoalOffGround);
  ASSERT_TRUE(start.ok()) << start.error().message;
  ASSERT_TRUE(goal.ok()) << goal.error().message;
  EXPECT_NEAR(goal->position_m.z(), L.landing_z_m + params.reference_height_m, 0.03);
  auto path = SearchPath(*graph, start->node, goal->node, SearchConfig{}, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  int on_ramp = 0;
  for (const Eigen::Vector3d& p : path->points_m) {
    const bool over_stairs = p.x() > L.stairs_x_min_m + 0.1 && p.x() < L.stairs_x_max_m - 0.1 &&
                             p.y() > L.stairs_y_min_m + 0.1 && p.y() < L.stairs_y_max_m - 0.1;
    EXPECT_FALSE(over_stairs) << p.transpose();
    // Columns straddling the ramp's side edges hold its surface too: widen by a cell.
    const bool over_ramp = p.x() > L.ramp_x_min_m - 0.1 && p.x() < L.ramp_x_max_m + 0.1 &&
                           p.y() > L.ramp_y_min_m + 0.5 && p.y() < L.ramp_y_max_m - 0.5;
    if (over_ramp) ++on_ramp;
    EXPECT_TRUE(test_util::GroundHeightBelow(*model, p).has_value()) << p.transpose();
  }
  EXPECT_GT(on_ramp, 10);
}

TEST(SearchState, AShortSearchOnALargeGraphCostsWhatItVisits) {
  // A flat 120 m x 120 m floor at 0.2 m: about 360,000 nodes. A 2 m search touches a few
  // hundred of them; its state must be a few pages and a directory of 4 bytes per 256 nodes,
  // not arrays the size of the graph (13+ bytes per node).
  PointCloud cloud;
  for (double x = 0; x < 120; x += 0.1) {
    for (double y = 0; y < 120; y += 0.1) cloud.emplace_back(x, y, 0.0);
  }
  AssessmentConfig config;
  auto model = TerrainModel::Assess(cloud, config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  auto graph = SurfaceGraph::Build(**model, TraversabilityParams{});
  ASSERT_TRUE(graph.ok());
  ASSERT_GT(graph->node_count(), 300000);
  auto start = SnapToSurface(*graph, {60, 60, 0.3}, 0.5, ErrorCode::kStartOffGround);
  auto goal = SnapToSurface(*graph, {62, 60, 0.3}, 0.5, ErrorCode::kGoalOffGround);
  ASSERT_TRUE(start.ok() && goal.ok());
  SearchStats stats;
  auto path = SearchPath(*graph, start->node, goal->node, SearchConfig{}, {}, &stats);
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_GT(stats.reached_nodes, 10u);
  EXPECT_LT(stats.reached_nodes, 2000u);
  const std::size_t directory = static_cast<std::size_t>(graph->node_count()) / 256 * 4;
  EXPECT_LT(stats.state_bytes, directory + 64 * 4096) << stats.reached_nodes << " nodes reached";
  EXPECT_LT(stats.state_bytes, static_cast<std::size_t>(graph->node_count()));
}

// The graph is undirected (surface_graph.hpp): whenever b is a neighbour of a, a is one of b,
// including diagonal moves between columns of different heights, where the corner-cutting
// rule must judge both ends alike. Components and A* rely on it.
class EdgeSymmetry : public ::testing::TestWithParam<const char*> {};

TEST_P(EdgeSymmetry, EveryEdgeRunsBothWays) {
  const Expected<PointCloud> cloud = GenerateScene(GetParam(), 4);
  ASSERT_TRUE(cloud.ok());
  AssessmentConfig config;
  config.grid.resolution_m = 0.2;
  auto model = TerrainModel::Assess(*cloud, config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  for (const TraversabilityParams& params :
       {TraversabilityParams{}, BuiltinProfile("biped")->Traversability()}) {
    auto graph = SurfaceGraph::Build(**model, params);
    ASSERT_TRUE(graph.ok()) << graph.error().message;
    int diagonal_edges = 0;
    for (int a = 0; a < graph->node_count(); ++a) {
      graph->ForEachNeighbor(a, [&](int b) {
        ASSERT_TRUE(AreNeighbors(*graph, b, a))
            << "edge " << graph->position(a).transpose() << " -> " << graph->position(b).transpose()
            << " has no way back";
        const Eigen::Vector2i d = graph->column(b) - graph->column(a);
        diagonal_edges += d.x() != 0 && d.y() != 0 && graph->ground_z(a) != graph->ground_z(b);
      });
    }
    EXPECT_GT(diagonal_edges, 100);  // The property was tested where it is delicate.
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, EdgeSymmetry,
                         ::testing::Values("uneven_terrain", "stairs_ramp_room", "parking_garage"));

// The shared spiral garage, assessed once for the tests below (skipped where the shared maps
// are not beside the checkout).
class Spiral : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string path = std::string(STRATA_SHARED_MAPS_DIR) + "/spiral0.3_2.pcd";
    if (!std::filesystem::exists(path)) return;
    const Expected<LoadedCloud> cloud = LoadPointCloud(path);
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    auto model = TerrainModel::Assess(cloud->points, AssessmentConfig{});
    ASSERT_TRUE(model.ok()) << model.error().message;
    model_ = std::move(model).value();
    auto graph = SurfaceGraph::Build(*model_, TraversabilityParams{});
    ASSERT_TRUE(graph.ok());
    graph_ = std::make_unique<SurfaceGraph>(std::move(graph).value());
  }
  static void TearDownTestSuite() {
    graph_.reset();
    model_.reset();
  }
  void SetUp() override {
    if (graph_ == nullptr) GTEST_SKIP() << "spiral0.3_2.pcd is not in " << STRATA_SHARED_MAPS_DIR;
  }
  static std::shared_ptr<const TerrainModel> model_;
  static std::unique_ptr<SurfaceGraph> graph_;
};
std::shared_ptr<const TerrainModel> Spiral::model_;
std::unique_ptr<SurfaceGraph> Spiral::graph_;

TEST_F(Spiral, EveryEdgeRunsBothWays) {
  // The spiral's voxel staircases have corners where one side column is a step below a and
  // the other level with b: a rule judged from a alone let a move one way only (3 of its
  // million edges).
  int one_way = 0;
  for (int a = 0; a < graph_->node_count(); ++a) {
    graph_->ForEachNeighbor(a, [&](int b) { one_way += !AreNeighbors(*graph_, b, a); });
  }
  EXPECT_EQ(one_way, 0);
}

TEST_F(Spiral, TopDeckToGroundSearchesFromTheGroundUp) {
  // sp_top_to_ground: the landmark that bounds its cost lies behind the start, on the top
  // deck, so from the start the bound is flat over the helical ramp's whole width; from the
  // goal it rises. Forward, the search expanded 12,584 nodes; from the goal about 5,100.
  const auto node = [&](const Eigen::Vector3d& p) {
    auto snapped = SnapToSurface(*graph_, p, 1.0, ErrorCode::kStartOffGround);
    EXPECT_TRUE(snapped.ok());
    return snapped.ok() ? snapped->node : -1;
  };
  const int start = node({-16, -23, 21.5});
  const int goal = node({-18, 0, 1.5});
  ASSERT_GE(start, 0);
  ASSERT_GE(goal, 0);
  const SearchConfig config;
  EXPECT_TRUE(graph_->ShouldSearchBackward(start, goal, config));
  EXPECT_FALSE(graph_->ShouldSearchBackward(goal, start, config));
  auto path = SearchPath(*graph_, start, goal, config, {});
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_EQ(path->nodes.front(), start);
  EXPECT_EQ(path->nodes.back(), goal);
  EXPECT_LT(path->expansions, 7000);
}

TEST(EdgeDistance, IsTheChamferDistanceFromTheRimUpToItsCap) {
  // Reference: a Dijkstra over every node from the nodes missing a neighbour, uncapped.
  const Expected<PointCloud> cloud = GenerateScene("parking_garage", 2);
  ASSERT_TRUE(cloud.ok());
  AssessmentConfig config;
  config.grid.resolution_m = 0.25;
  auto model = TerrainModel::Assess(*cloud, config);
  ASSERT_TRUE(model.ok());
  auto graph = SurfaceGraph::Build(**model, TraversabilityParams{});
  ASSERT_TRUE(graph.ok());
  const double r = graph->grid().resolution_m;
  std::vector<double> reference(graph->node_count(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (int a = 0; a < graph->node_count(); ++a) {
    int neighbours = 0;
    graph->ForEachNeighbor(a, [&](int) { ++neighbours; });
    if (neighbours < 8) queue.push({reference[a] = 0.5 * r, a});
  }
  while (!queue.empty()) {
    const auto [d, a] = queue.top();
    queue.pop();
    if (d > reference[a]) continue;
    graph->ForEachNeighbor(a, [&, d = d, a = a](int b) {
      const Eigen::Vector2i step = graph->column(b) - graph->column(a);
      const double next = d + (step.x() != 0 && step.y() != 0 ? std::sqrt(2.0) * r : r);
      if (next < reference[b]) queue.push({reference[b] = next, b});
    });
  }
  const double cap = SurfaceGraph::EdgeDistanceCap(r);
  int interior = 0;
  for (int a = 0; a < graph->node_count(); ++a) {
    ASSERT_NEAR(graph->edge_distance(a), std::min(reference[a], cap), 1e-4) << "node " << a;
    interior += reference[a] > cap;
  }
  EXPECT_GT(interior, 1000);  // The cap was reached, so the comparison covers it.
}

}  // namespace
}  // namespace strata
