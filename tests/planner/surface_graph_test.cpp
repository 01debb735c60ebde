// SurfaceGraph on a small hand-made map, against brute-force readings of its class comment:
// the nodes, the step rule and the corner rule of the edges, the components, the edge
// distance, and SnapToSurface.
#include "strata/planning/surface_graph.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <queue>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

constexpr double kDegree = std::numbers::pi / 180;

// A floor 6 × 4 m at z = 0 with: a slab 0.45 m above it over [1, 2] × [1, 2] (too low for a
// 0.5 m body, its top another level); a 25° ramp up +x over [3.5, 4.5] × [1, 3] to a plateau
// (valid ground on a map filtered at 30°, too steep for a robot allowed 20°); a platform
// 0.12 m high (a step a robot climbs) and one 0.3 m high (a step it does not); two square
// holes in the floor touching at one corner (diagonal moves past that corner cut no corner).
PointCloud GraphYard() {
  const auto in_hole = [](double x, double y) {
    return (x > 2.2 && x < 2.6 && y > 0.2 && y < 0.6) || (x > 2.6 && x < 3.0 && y > 0.6 && y < 1.0);
  };
  const auto raised = [](double x, double y) {
    return (x > 3.49 && y > 0.99 && y < 3.01) || (y > 2.99 && y < 3.51 && x > 0.49 && x < 1.01) ||
           (y > 2.99 && y < 3.51 && x > 2.49 && x < 3.01);
  };
  test_util::CloudBuilder b(0.05);
  b.Surface(
      0, 6, 0, 4, [](double, double) { return 0.0; },
      [&](double x, double y) { return !in_hole(x, y) && !raised(x, y); });
  b.Plate(1, 2, 1, 2, 0.45);
  const double tan25 = std::tan(25 * kDegree);
  b.Surface(3.5, 4.5, 1, 3, [&](double x, double) { return (x - 3.5) * tan25; });
  b.Plate(4.55, 6, 1, 3, tan25);
  b.Plate(0.5, 1, 3, 3.5, 0.12);
  b.Plate(2.5, 3, 3, 3.5, 0.3);
  return b.cloud();
}

const TerrainModel& Model() {
  static const std::shared_ptr<const TerrainModel> model = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    config.ground.max_tilt_rad = 30 * kDegree;
    return TerrainModel::Assess(GraphYard(), config).value();
  }();
  return *model;
}

TraversabilityParams Params() {
  TraversabilityParams p;
  p.reference_height_m = 0.3;
  p.body_height_m = 0.5;
  p.max_tilt_rad = 20 * kDegree;
  p.max_step_m = 0.15;
  return p;
}

const SurfaceGraph& Graph() {
  static const SurfaceGraph graph = SurfaceGraph::Build(Model(), Params()).value();
  return graph;
}

// What the class comment says a node is, read off the surfaces directly.
bool QualifiesAsNode(const ColumnSurface& s, const GridGeometry& g, const TraversabilityParams& p) {
  const double reference_z = s.ground_z_m + p.reference_height_m;
  return s.valid && s.tilt_rad <= p.max_tilt_rad && s.clearance_m >= p.body_height_m &&
         reference_z >= g.origin_m.z() &&
         reference_z < g.origin_m.z() + g.size.z() * g.resolution_m;
}

TEST(SurfaceGraph, HasANodeOnExactlyTheSurfacesTheClassCommentAllows) {
  const SurfaceGraph& graph = Graph();
  const GridGeometry& g = Model().grid();
  int expected = 0, previous = -1;
  std::set<std::pair<int, int>> kinds;  // (valid, qualifies) pairs seen, to know the map bites.
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      const auto column = Model().surfaces().Column(ix, iy);
      const auto nodes = graph.ColumnNodes(ix, iy);
      std::size_t next = 0;
      int level = 0;
      for (const ColumnSurface& s : column) {
        const int this_level = s.valid ? level++ : -1;
        const bool qualifies = QualifiesAsNode(s, g, Params());
        kinds.insert({s.valid, qualifies});
        if (!qualifies) continue;
        ++expected;
        ASSERT_LT(next, nodes.size()) << "missing node at column " << ix << ", " << iy;
        const int node = nodes[next++];
        EXPECT_GT(node, previous) << "nodes are stored column by column, lowest first";
        previous = node;
        EXPECT_EQ(&graph.surface(node), &s);
        EXPECT_EQ(graph.column(node), Eigen::Vector2i(ix, iy));
        EXPECT_EQ(graph.level(node), this_level);
        const Eigen::Vector3d p(g.origin_m.x() + (ix + 0.5) * g.resolution_m,
                                g.origin_m.y() + (iy + 0.5) * g.resolution_m,
                                s.ground_z_m + Params().reference_height_m);
        EXPECT_LT((graph.position(node) - p).norm(), 1e-5);
        EXPECT_EQ(graph.cell(node), g.CellOf(p));
        EXPECT_NEAR(graph.ground_z(node), s.ground_z_m, 1e-5);
        EXPECT_NEAR(graph.clearance(node), Model().Distance(p), 1e-5);
      }
      EXPECT_EQ(next, nodes.size()) << "extra node at column " << ix << ", " << iy;
    }
  }
  EXPECT_EQ(graph.node_count(), expected);
  // The map has valid surfaces that qualify and valid ones that do not (too steep, too low).
  EXPECT_EQ(kinds.count({1, 1}), 1u);
  EXPECT_EQ(kinds.count({1, 0}), 1u);
}

// Adjacency as the class comment states it, for node a and a node b of a neighbouring column.
bool Adjacent(const SurfaceGraph& graph, int a, int b) {
  const Eigen::Vector2i d = graph.column(b) - graph.column(a);
  if (d.cwiseAbs().maxCoeff() != 1) return false;
  const double r = graph.grid().resolution_m;
  const TraversabilityParams& p = graph.params();
  const auto within = [&](int m, int n, double s) {
    return std::abs(graph.ground_z(m) - graph.ground_z(n)) <=
           p.max_step_m + s * std::tan(p.max_tilt_rad) + 1e-6;
  };
  const bool diagonal = d.x() != 0 && d.y() != 0;
  if (!within(a, b, diagonal ? r * std::sqrt(2.0) : r)) return false;
  if (!diagonal) return true;
  const auto side_has_step_neighbour = [&](const Eigen::Vector2i& c) {
    for (const int m : graph.ColumnNodes(c.x(), c.y())) {
      if (within(a, m, r)) return true;
    }
    return false;
  };
  const Eigen::Vector2i c = graph.column(a);
  return side_has_step_neighbour({c.x() + d.x(), c.y()}) &&
         side_has_step_neighbour({c.x(), c.y() + d.y()});
}

TEST(SurfaceGraph, OpenGroundClearanceIsWhatNineNodesInTenKeep) {
  const SurfaceGraph& graph = Graph();
  const double open = graph.open_ground_clearance_m();
  int below = 0, at_least = 0;
  for (int node = 0; node < graph.node_count(); ++node) {
    (graph.clearance(node) < open ? below : at_least) += 1;
  }
  EXPECT_LE(below, graph.node_count() / 10);
  EXPECT_GE(at_least, graph.node_count() * 9 / 10);
  // The ground itself is an obstacle: open ground keeps about the reference height from it.
  EXPECT_GT(open, 0.0);
  EXPECT_LE(open, Params().reference_height_m + Model().grid().resolution_m);
}

TEST(SurfaceGraph, EdgesFollowTheStepRuleAndCutNoCorner) {
  const SurfaceGraph& graph = Graph();
  int edges = 0, steps_refused = 0, corners_refused = 0, climbed = 0;
  for (int a = 0; a < graph.node_count(); ++a) {
    std::set<int> neighbours;
    graph.ForEachNeighbor(a, [&](int b) { neighbours.insert(b); });
    const Eigen::Vector2i c = graph.column(a);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        for (const int b : graph.ColumnNodes(c.x() + dx, c.y() + dy)) {
          const bool adjacent = Adjacent(graph, a, b);
          ASSERT_EQ(neighbours.count(b) > 0, adjacent) << "nodes " << a << " and " << b;
          edges += adjacent;
          const double rise = std::abs(graph.ground_z(a) - graph.ground_z(b));
          climbed += adjacent && rise > 0.1;
          if (!adjacent) (dx != 0 && dy != 0 && rise < 0.01 ? corners_refused : steps_refused)++;
        }
      }
    }
    for (const int b : neighbours) {
      EXPECT_NE(graph.column(a), graph.column(b)) << "nodes of one column are never adjacent";
      bool back = false;
      graph.ForEachNeighbor(b, [&](int m) { back = back || m == a; });
      EXPECT_TRUE(back) << "edges are undirected: " << a << " -> " << b << " but not back";
    }
  }
  EXPECT_GT(edges, 0);
  EXPECT_GT(climbed, 0) << "the 0.12 m platform is a step the robot climbs";
  EXPECT_GT(steps_refused, 0) << "the slab, the 0.3 m platform: steps it does not";
  EXPECT_GT(corners_refused, 0) << "past the holes' shared corner, a diagonal cuts a corner";
}

TEST(SurfaceGraph, ComponentsAreTheConnectedPartsOfTheEdges) {
  const SurfaceGraph& graph = Graph();
  // Breadth-first search over ForEachNeighbor as the reference labelling.
  std::vector<int> label(graph.node_count(), -1);
  int count = 0;
  for (int seed = 0; seed < graph.node_count(); ++seed) {
    if (label[seed] >= 0) continue;
    std::queue<int> open;
    open.push(seed);
    label[seed] = count;
    while (!open.empty()) {
      const int n = open.front();
      open.pop();
      graph.ForEachNeighbor(n, [&](int m) {
        if (label[m] < 0) label[m] = count, open.push(m);
      });
    }
    ++count;
  }
  EXPECT_EQ(graph.component_count(), count);
  std::map<int, int> to_reference;
  for (int n = 0; n < graph.node_count(); ++n) {
    ASSERT_GE(graph.component(n), 0);
    ASSERT_LT(graph.component(n), graph.component_count());
    const auto [it, inserted] = to_reference.emplace(graph.component(n), label[n]);
    EXPECT_EQ(it->second, label[n]) << "node " << n;
  }
  // The floor, the slab's top, the plateau beyond the steep ramp and the 0.3 m platform are
  // separate; the 0.12 m platform is part of the floor's.
  const auto node_at = [&](double x, double y, double ground_z) {
    const Eigen::Vector3i c = Model().grid().CellOf({x, y, 0});
    return graph.NodeNear(c.x(), c.y(), ground_z);
  };
  const int floor = node_at(0.3, 0.3, 0), slab = node_at(1.5, 1.5, 0.45),
            plateau = node_at(5.5, 2, std::tan(25 * kDegree)), high = node_at(2.75, 3.25, 0.3),
            low = node_at(0.75, 3.25, 0.12);
  for (const int n : {floor, slab, plateau, high, low}) ASSERT_GE(n, 0);
  const std::set<int> separate = {graph.component(floor), graph.component(slab),
                                  graph.component(plateau), graph.component(high)};
  EXPECT_EQ(separate.size(), 4u);
  EXPECT_EQ(graph.component(low), graph.component(floor));
}

TEST(SurfaceGraph, EdgeDistanceGrowsInwardsFromTheRim) {
  const SurfaceGraph& graph = Graph();
  const double r = graph.grid().resolution_m;
  int rim = 0, inner = 0;
  for (int a = 0; a < graph.node_count(); ++a) {
    std::vector<int> neighbours;
    graph.ForEachNeighbor(a, [&](int b) { neighbours.push_back(b); });
    if (neighbours.size() < 8) {
      EXPECT_FLOAT_EQ(graph.edge_distance(a), 0.5 * r);
      ++rim;
      continue;
    }
    // Inside: the chamfer distance is the shortest way to the rim along the edges.
    double best = std::numeric_limits<double>::infinity();
    for (const int b : neighbours) {
      const bool diagonal = (graph.column(a) - graph.column(b)).cwiseAbs().sum() == 2;
      best = std::min(best, graph.edge_distance(b) + (diagonal ? std::sqrt(2.0) * r : r));
    }
    EXPECT_NEAR(graph.edge_distance(a), best, 1e-5) << "node " << a;
    EXPECT_GT(graph.edge_distance(a), 0.5 * r);
    ++inner;
  }
  EXPECT_GT(rim, 0);
  EXPECT_GT(inner, rim);
}

TEST(SurfaceGraph, NodeNearFindsTheLevelWithinHalfAMetre) {
  const SurfaceGraph& graph = Graph();
  const Eigen::Vector3i slab = Model().grid().CellOf({1.5, 1.5, 0});
  // Under the slab the floor is no node (clearance 0.45 < 0.5): its only node is the top.
  ASSERT_EQ(graph.ColumnNodes(slab.x(), slab.y()).size(), 1u);
  EXPECT_GE(graph.NodeNear(slab.x(), slab.y(), 0.45), 0);
  EXPECT_GE(graph.NodeNear(slab.x(), slab.y(), 0.0), 0) << "0.45 m is within the level gap";
  EXPECT_EQ(graph.NodeNear(slab.x(), slab.y(), -0.1), -1);
  EXPECT_EQ(graph.NodeNear(-5, -5, 0), -1);
}

// The band NodeNear reports (what SampleEdgeDistance's DeepInside rests on): the same node at
// every height inside it, and another answer a little beyond each end, in every column that
// has a node. A robot low enough for the floor under the slab has two levels 0.45 m apart
// there, nearer than twice kLevelGapM: their bands meet halfway.
TEST(SurfaceGraph, NodeNearGivesItsNodeAcrossItsBandAndNoFarther) {
  TraversabilityParams low_robot = Params();
  low_robot.reference_height_m = 0.1;
  low_robot.body_height_m = 0.3;
  const SurfaceGraph graph = SurfaceGraph::Build(Model(), low_robot).value();
  const GridGeometry& g = graph.grid();
  int bands = 0, near_levels = 0;
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      const auto nodes = graph.ColumnNodes(ix, iy);
      if (nodes.empty()) continue;
      near_levels +=
          nodes.size() == 2 && std::abs(graph.ground_z(nodes[1]) - graph.ground_z(nodes[0])) <
                                   2 * SurfaceGraph::kLevelGapM;
      for (const std::int32_t m : nodes) {
        double low = 0, high = 0;
        const double ground = graph.ground_z(m) + 0.1;
        const int node = graph.NodeNear(ix, iy, ground, &low, &high);
        ASSERT_EQ(node, graph.NodeNear(ix, iy, ground));
        ASSERT_GE(node, 0);
        ASSERT_LT(low, ground);
        ASSERT_GT(high, ground);
        for (double z = low; z < high; z += 0.01) {
          EXPECT_EQ(graph.NodeNear(ix, iy, z), node) << ix << " " << iy << " " << z;
        }
        EXPECT_EQ(graph.NodeNear(ix, iy, std::nextafter(high, 1e9)), node);
        EXPECT_NE(graph.NodeNear(ix, iy, high + 1e-4), node) << ix << " " << iy;
        EXPECT_NE(graph.NodeNear(ix, iy, low - 1e-4), node) << ix << " " << iy;
        ++bands;
      }
    }
  }
  double low = 1, high = 1;
  EXPECT_EQ(graph.NodeNear(0, 0, -100, &low, &high), -1);
  EXPECT_GE(low, high) << "no node, an empty band";
  EXPECT_GT(bands, 100);
  EXPECT_GT(near_levels, 50);
}

TEST(SnapToSurface, PicksTheLevelTheHeightPointsAtAndNamesTheNearestWhenNoneIsNear) {
  const SurfaceGraph& graph = Graph();
  const double ref = Params().reference_height_m;
  // On the floor in the open: its own column.
  auto snap = SnapToSurface(graph, {0.33, 0.33, ref}, 1.0, ErrorCode::kStartOffGround);
  ASSERT_TRUE(snap.ok()) << snap.error().message;
  EXPECT_EQ(graph.column(snap->node), graph.grid().CellOf({0.33, 0.33, 0}).head<2>());
  EXPECT_EQ(snap->level, 0);
  EXPECT_NEAR(snap->distance_m, std::hypot(0.02, 0.02), 0.02);
  // Above the slab: its top, the column's second level.
  snap = SnapToSurface(graph, {1.5, 1.5, 0.45 + ref}, 1.0, ErrorCode::kGoalOffGround);
  ASSERT_TRUE(snap.ok());
  EXPECT_NEAR(graph.ground_z(snap->node), 0.45, 1e-5);
  EXPECT_EQ(snap->level, 1);
  // Under the slab, where the floor is no node: the floor beside it, never the top above.
  snap = SnapToSurface(graph, {1.5, 1.5, ref}, 1.0, ErrorCode::kStartOffGround);
  ASSERT_TRUE(snap.ok());
  EXPECT_NEAR(graph.ground_z(snap->node), 0, 1e-5);
  EXPECT_GE((graph.position(snap->node).head<2>() - Eigen::Vector2d(1.5, 1.5)).norm(), 0.5);
  EXPECT_LE((graph.position(snap->node).head<2>() - Eigen::Vector2d(1.5, 1.5)).norm(), 0.65);
  // With a tolerance too small to reach the floor beside it, ground above the point is taken
  // (ground below is only preferred).
  snap = SnapToSurface(graph, {1.5, 1.5, ref}, 0.2, ErrorCode::kStartOffGround);
  ASSERT_TRUE(snap.ok());
  EXPECT_NEAR(graph.ground_z(snap->node), 0.45, 1e-5);
  // Too far from any node: the caller's code and the nearest node in the message.
  snap = SnapToSurface(graph, {3, 2, 4}, 0.2, ErrorCode::kGoalOffGround);
  ASSERT_FALSE(snap.ok());
  EXPECT_EQ(snap.error().code, ErrorCode::kGoalOffGround);
  EXPECT_THAT(snap.error().message, HasSubstr("goal (3.00, 2.00, 4.00) m"));
  EXPECT_THAT(snap.error().message, HasSubstr("within 0.20 m; the nearest is"));
  // The nearest point, machine-readable: a node's reference point, at the distance named.
  {
    const auto& details = snap.error().details;
    ASSERT_EQ(details.count("nearest_x_m"), 1u);
    const Eigen::Vector3d nearest(std::stod(details.at("nearest_x_m")),
                                  std::stod(details.at("nearest_y_m")),
                                  std::stod(details.at("nearest_z_m")));
    const auto at = SnapToSurface(graph, nearest, 1e-3, ErrorCode::kGoalOffGround);
    ASSERT_TRUE(at.ok()) << "the nearest point named is not on traversable ground";
    EXPECT_EQ(std::to_string(graph.level(at->node)), details.at("nearest_level"));
    EXPECT_GT(std::stod(details.at("nearest_distance_m")), 0.2);
    EXPECT_THAT(snap.error().message, HasSubstr(details.at("nearest_distance_m").substr(0, 3)));
  }
  // Malformed queries.
  snap = SnapToSurface(graph, {std::nan(""), 1, 1}, 1.0, ErrorCode::kStartOffGround);
  ASSERT_FALSE(snap.ok());
  EXPECT_EQ(snap.error().code, ErrorCode::kInvalidInput);
  snap = SnapToSurface(graph, {0.3, 0.3, ref}, -1, ErrorCode::kStartOffGround);
  ASSERT_FALSE(snap.ok());
  EXPECT_EQ(snap.error().code, ErrorCode::kInvalidInput);
}

// The nearest node a failed snap names is the nearest of all nodes, by the level distance the
// header defines (read here off every node, as a brute force), for points in the map's walls
// and holes, above and below it, beside it and far out of it.
TEST(SnapToSurface, NamesTheNearestOfAllNodesWhereverThePointIs) {
  const SurfaceGraph& graph = Graph();
  const GridGeometry& g = graph.grid();
  const auto level_distance = [&](int node, const Eigen::Vector3d& p) {
    const double ground = graph.ground_z(node);
    const double ceiling = ground + std::min<double>(graph.ceiling_clearance(node), 2.5);
    const double outside =
        std::max(0.0, ground - 0.5 * g.resolution_m - p.z()) + std::max(0.0, p.z() - ceiling);
    return std::hypot((graph.position(node) - p).head<2>().norm(), outside);
  };
  std::vector<Eigen::Vector3d> points = {
      {-100, 2, 0.3}, {3, 250, 1}, {-40, -40, -5}, {2.4, 0.4, 0}};
  std::mt19937 random(7);
  std::uniform_real_distribution<double> x(-3, 9), y(-3, 7), z(-1, 4);
  for (int k = 0; k < 300; ++k) points.emplace_back(x(random), y(random), z(random));
  int named = 0;
  for (const Eigen::Vector3d& p : points) {
    const auto snap = SnapToSurface(graph, p, 0.05, ErrorCode::kGoalOffGround);
    if (snap.ok()) continue;
    double nearest = std::numeric_limits<double>::infinity();
    for (int m = 0; m < graph.node_count(); ++m) nearest = std::min(nearest, level_distance(m, p));
    ASSERT_EQ(snap.error().details.count("nearest_distance_m"), 1u) << p.transpose();
    EXPECT_NEAR(std::stod(snap.error().details.at("nearest_distance_m")), nearest,
                1e-5 * std::max(1.0, nearest))
        << p.transpose();
    ++named;
  }
  EXPECT_GT(named, 100);
}

// A node `accept` turns down is never snapped to: the nearest accepted one within tolerance
// is, and when none is, the error names what the refused nodes lack.
TEST(SnapToSurface, SnapsOnlyToAcceptedNodes) {
  const SurfaceGraph& graph = Graph();
  const double ref = Params().reference_height_m;
  const Eigen::Vector3d p(0.33, 0.33, ref);
  const auto own = SnapToSurface(graph, p, 1.0, ErrorCode::kStartOffGround);
  ASSERT_TRUE(own.ok());
  const int refused = own->node;
  const auto other = SnapToSurface(graph, p, 1.0, ErrorCode::kStartOffGround,
                                   [&](int node) { return node != refused; });
  ASSERT_TRUE(other.ok()) << other.error().message;
  EXPECT_NE(other->node, refused);
  EXPECT_LE((graph.position(other->node) - graph.position(refused)).head<2>().norm(),
            std::sqrt(2.0) * graph.grid().resolution_m + 1e-9);  // A neighbouring column.
  const auto none = SnapToSurface(
      graph, p, 1.0, ErrorCode::kGoalOffGround, [](int) { return false; }, "too close to a wall");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::kGoalOffGround);
  EXPECT_THAT(none.error().message, HasSubstr("all traversable ground within 1.00 m puts the "
                                              "robot's reference point too close to a wall"));
}

TEST(SurfaceGraph, BuildRefusesBadParametersNamingTheField) {
  TraversabilityParams p = Params();
  p.reference_height_m = 0.6;  // Above the body.
  auto graph = SurfaceGraph::Build(Model(), p);
  ASSERT_FALSE(graph.ok());
  EXPECT_EQ(graph.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(graph.error().message, HasSubstr("traversability.reference_height_m"));
  p = Params();
  p.max_step_m = -1;
  graph = SurfaceGraph::Build(Model(), p);
  ASSERT_FALSE(graph.ok());
  EXPECT_THAT(graph.error().message, HasSubstr("traversability.max_step_m"));
  p = Params();
  p.max_tilt_rad = 35 * kDegree;  // Steeper than the map's filter ever marked valid.
  graph = SurfaceGraph::Build(Model(), p);
  ASSERT_FALSE(graph.ok());
  EXPECT_EQ(graph.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(graph.error().message, HasSubstr("ground.max_tilt_rad"));
}

}  // namespace
}  // namespace strata
