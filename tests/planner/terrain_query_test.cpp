// The terrain queries shared by the optimiser's costs and the final verification: exact at
// column centres, and their gradients match finite differences where the interpolation is
// smooth.
#include "strata/planning/terrain_query.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "test_util/two_level_scene.hpp"

namespace strata {
namespace {

const TerrainModel& Scene() { return test_util::TwoLevelScene(); }

const SurfaceGraph& Graph() {
  static const SurfaceGraph graph = SurfaceGraph::Build(Scene(), TraversabilityParams{}).value();
  return graph;
}

// Seeded nodes of the graph, and points near them off the lines through column centres
// (where the bilinear interpolation has kinks).
std::vector<Eigen::Vector3d> PointsNearNodes(int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> node(0, Graph().node_count() - 1);
  std::uniform_real_distribution<double> offset(0.05, 0.45);
  std::bernoulli_distribution sign(0.5);
  const double r = Scene().grid().resolution_m;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d p = Graph().position(node(rng));
    p.x() += (sign(rng) ? 1 : -1) * offset(rng) * r;
    p.y() += (sign(rng) ? 1 : -1) * offset(rng) * r;
    points.push_back(p);
  }
  return points;
}

// Seeded points within a cell and a half of rim nodes (in the columns beside them, missing
// columns included), at the rim node's reference height.
std::vector<Eigen::Vector3d> PointsNearTheRim(int count, std::uint32_t seed) {
  const SurfaceGraph& graph = Graph();
  const double r = Scene().grid().resolution_m;
  std::vector<int> rim;
  for (int node = 0; node < graph.node_count(); ++node) {
    if (graph.edge_distance(node) <= 0.5 * r + 1e-6) rim.push_back(node);
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, rim.size() - 1);
  std::uniform_real_distribution<double> offset(-1.5 * r, 1.5 * r);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d p = graph.position(rim[pick(rng)]);
    p.x() += offset(rng);
    p.y() += offset(rng);
    points.push_back(p);
  }
  return points;
}

// The definition, evaluated naively: the distance from p to the nearest column square of the
// other kind (traversable at p's level or not) within a wide window, signed, clamped at reach.
double BruteForceEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p, double reach_m) {
  const GridGeometry& g = graph.grid();
  const double r = g.resolution_m;
  const double z = p.z() - graph.params().reference_height_m;
  const auto traversable = [&](int ix, int iy) {
    return ix >= 0 && iy >= 0 && ix < g.size.x() && iy < g.size.y() &&
           graph.NodeNear(ix, iy, z) >= 0;
  };
  const Eigen::Vector3i c = g.CellOf(p);
  const bool inside = traversable(c.x(), c.y());
  double nearest = std::numeric_limits<double>::infinity();
  for (int iy = c.y() - 10; iy <= c.y() + 10; ++iy) {
    for (int ix = c.x() - 10; ix <= c.x() + 10; ++ix) {
      if (traversable(ix, iy) == inside) continue;
      const double x0 = g.origin_m.x() + ix * r, y0 = g.origin_m.y() + iy * r;
      const double dx = std::max({x0 - p.x(), 0.0, p.x() - (x0 + r)});
      const double dy = std::max({y0 - p.y(), 0.0, p.y() - (y0 + r)});
      nearest = std::min(nearest, std::hypot(dx, dy));
    }
  }
  const double cap = std::max(1.0, std::ceil(reach_m / r)) * r;
  return (inside ? 1 : -1) * std::min(nearest, cap);
}

TEST(SampleEdgeDistance, IsTheSignedDistanceToTheNearestColumnOfTheOtherKind) {
  const SurfaceGraph& graph = Graph();
  int outside = 0;
  for (const double reach : {0.1, 0.25}) {
    for (const Eigen::Vector3d& p : PointsNearTheRim(400, 5)) {
      Eigen::Vector2d gradient;
      const double e = SampleEdgeDistance(graph, p, reach, &gradient);
      EXPECT_NEAR(e, BruteForceEdgeDistance(graph, p, reach), 1e-9) << p.transpose();
      outside += e < 0;
    }
  }
  EXPECT_GT(outside, 50);  // The points reach into missing columns.
}

TEST(SampleEdgeDistance, GradientMatchesFiniteDifferences) {
  const double h = 1e-7;
  int moving = 0;
  for (const Eigen::Vector3d& p : PointsNearTheRim(300, 3)) {
    Eigen::Vector2d gradient, unused;
    SampleEdgeDistance(Graph(), p, 0.1, &gradient);
    moving += gradient.norm() > 0;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step(axis) = h;
      const double numeric = (SampleEdgeDistance(Graph(), p + step, 0.1, &unused) -
                              SampleEdgeDistance(Graph(), p - step, 0.1, &unused)) /
                             (2 * h);
      EXPECT_NEAR(gradient(axis), numeric, 1e-5) << p.transpose() << " axis " << axis;
    }
  }
  EXPECT_GT(moving, 100);  // Most points are within reach of the rim, not clamped.
}

// Where SampleEdgeDistance reports p deep inside, every point IsDeepInside accepts gets the
// same distance and a zero gradient (what the optimiser's TerrainMemo skips), and points
// beyond the column or the band are refused.
TEST(SampleEdgeDistance, IsTheSameWhereverItsDeepInsideAnswerHolds) {
  const SurfaceGraph& graph = Graph();
  const double r = Scene().grid().resolution_m, reach = 0.1;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> offset(-1.0, 1.0);
  int deep_points = 0, accepted = 0, refused = 0;
  for (const Eigen::Vector3d& p : PointsNearNodes(300, 8)) {
    Eigen::Vector2d gradient;
    DeepInside deep;
    const double e = SampleEdgeDistance(graph, p, reach, &gradient, &deep);
    if (deep.ix < 0) continue;
    ++deep_points;
    EXPECT_TRUE(IsDeepInside(graph, p, deep));
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d q = p + Eigen::Vector3d(offset(rng) * r, offset(rng) * r,
                                                    offset(rng) * 3 * SurfaceGraph::kLevelGapM);
      if (!IsDeepInside(graph, q, deep)) {
        ++refused;
        continue;
      }
      ++accepted;
      Eigen::Vector2d q_gradient;
      EXPECT_EQ(SampleEdgeDistance(graph, q, reach, &q_gradient), e) << q.transpose();
      EXPECT_EQ(q_gradient, Eigen::Vector2d::Zero());
    }
  }
  EXPECT_GT(deep_points, 50);
  EXPECT_GT(accepted, 200);
  EXPECT_GT(refused, 500);
}

// A seeded walk as an optimiser's constraint points move: small steps, mostly within a cell,
// now and then onto another level of the same column (the two-level scene's deck and the
// ground under it), well off the ground, or somewhere else.
std::vector<Eigen::Vector3d> WalkAcrossLevels(int count, std::uint32_t seed) {
  const SurfaceGraph& graph = Graph();
  const double r = Scene().grid().resolution_m;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> node(0, graph.node_count() - 1);
  std::uniform_real_distribution<double> step(-0.15 * r, 0.15 * r);
  std::uniform_real_distribution<double> rise(-0.4, 0.4);
  std::uniform_real_distribution<double> event(0.0, 1.0);
  Eigen::Vector3d p = graph.position(node(rng));
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double e = event(rng);
    if (e < 0.02) {
      p = graph.position(node(rng));
    } else if (e < 0.12) {
      const Eigen::Vector3i cell = Scene().grid().CellOf(p);
      const auto nodes = graph.ColumnNodes(cell.x(), cell.y());
      if (!nodes.empty()) p.z() = graph.position(nodes[i % nodes.size()]).z();
    } else if (e < 0.2) {
      p.z() += rise(rng);
    } else {
      p.x() += step(rng);
      p.y() += step(rng);
    }
    points.push_back(p);
  }
  return points;
}

// The optimiser keeps each constraint point's GroundChoice from one evaluation to the next: it
// must never change an answer, only skip the column scans.
TEST(SampleGround, AKeptChoiceGivesTheSameAnswersAsAFreshOne) {
  const double h_ref = Graph().params().reference_height_m;
  GroundChoice choice;
  int kept = 0, level_changed = 0;
  const std::vector<Eigen::Vector3d> walk = WalkAcrossLevels(6000, 11);
  for (std::size_t i = 0; i < walk.size(); ++i) {
    const Eigen::Vector3d& p = walk[i];
    // Two caps in turn: a choice's clearances hold for the cap they were found with.
    const double cap = (i / 500) % 2 == 0 ? 3.0 : 2.0;
    const Eigen::Vector2i previous_cell = choice.cell;
    const ColumnSurface* previous_corner = choice.corner[0][0];
    GroundSample fresh, with_choice;
    const bool fresh_ok = SampleGround(Scene(), p, h_ref, cap, &fresh);
    ASSERT_EQ(SampleGround(Scene(), p, h_ref, cap, &with_choice, &choice), fresh_ok) << i;
    kept += choice.cell == previous_cell;
    level_changed += choice.cell == previous_cell && choice.corner[0][0] != previous_corner;
    if (!fresh_ok) continue;
    EXPECT_EQ(fresh.height_m, with_choice.height_m) << i;
    EXPECT_EQ(fresh.height_gradient, with_choice.height_gradient) << i;
    EXPECT_EQ(fresh.clearance_m, with_choice.clearance_m) << i;
    EXPECT_EQ(fresh.clearance_gradient, with_choice.clearance_gradient) << i;
    EXPECT_EQ(fresh.surface, with_choice.surface) << i;
  }
  // The walk stays in its cells often enough to use the choice, and changes level within one.
  EXPECT_GT(kept, 2000);
  EXPECT_GT(level_changed, 20);
}

// Where GroundWithinBand answers for a kept choice, SampleGround must find the ground within
// the band (or none); and on the scene's floors and ramp it must answer often.
TEST(GroundWithinBand, HoldsOnlyWhereTheSampledGroundIsWithinTheBand) {
  const double h_ref = Graph().params().reference_height_m;
  const double band = 0.01;
  GroundChoice choice;
  int within = 0, not_within = 0;
  for (const Eigen::Vector3d& p : WalkAcrossLevels(6000, 12)) {
    const bool claimed = GroundWithinBand(choice, p, h_ref, band);
    GroundSample ground;
    const bool found = SampleGround(Scene(), p, h_ref, 0, &ground, &choice);
    (claimed ? within : not_within) += 1;
    if (claimed && found) {
      EXPECT_LE(std::abs(p.z() - h_ref - ground.height_m), band) << p.transpose();
    }
  }
  EXPECT_GT(within, 1000);
  EXPECT_GT(not_within, 1000);
}

// Where GroundHeightRange answers for a box between a choice's column centres and a band of
// ground heights, SampleGround's ground at every point of both lies in its range; on the
// scene's floors and ramp it must answer often, and the range must be attained (at a corner).
TEST(GroundHeightRange, BoundsTheSampledGroundOverABoxAndABand) {
  const GridGeometry& grid = Scene().grid();
  const double h_ref = Graph().params().reference_height_m;
  const double r = grid.resolution_m;
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  GroundChoice choice;
  int answered = 0, unanswered = 0;
  for (const Eigen::Vector3d& p : WalkAcrossLevels(3000, 14)) {
    GroundSample at_p;
    if (!SampleGround(Scene(), p, h_ref, 0, &at_p, &choice)) continue;
    const Eigen::Vector2d half(0.3 * r * unit(rng), 0.3 * r * unit(rng));
    const Eigen::AlignedBox2d box =
        Eigen::AlignedBox2d(p.head<2>() - half, p.head<2>() + half).intersection(choice.area);
    const double feet = p.z() - h_ref;
    const double band = 0.05 * unit(rng);
    double low = 0, high = 0;
    if (!GroundHeightRange(Scene(), choice, box, 0, feet - band, feet + band, &low, &high)) {
      ++unanswered;
      continue;
    }
    ++answered;
    ASSERT_LE(low, high);
    for (int k = 0; k < 40; ++k) {
      const Eigen::Vector3d q(box.min().x() + box.sizes().x() * unit(rng),
                              box.min().y() + box.sizes().y() * unit(rng),
                              p.z() + band * (2 * unit(rng) - 1));
      GroundSample at_q;
      ASSERT_TRUE(SampleGround(Scene(), q, h_ref, 0, &at_q)) << q.transpose();
      EXPECT_GE(at_q.height_m, low - 1e-9) << q.transpose();
      EXPECT_LE(at_q.height_m, high + 1e-9) << q.transpose();
    }
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
    for (const auto corner : {Eigen::AlignedBox2d::BottomLeft, Eigen::AlignedBox2d::BottomRight,
                              Eigen::AlignedBox2d::TopLeft, Eigen::AlignedBox2d::TopRight}) {
      GroundSample at_corner;
      const Eigen::Vector2d c = box.corner(corner);
      ASSERT_TRUE(SampleGround(Scene(), {c.x(), c.y(), p.z()}, h_ref, 0, &at_corner));
      lowest = std::min(lowest, at_corner.height_m);
      highest = std::max(highest, at_corner.height_m);
    }
    EXPECT_NEAR(low, lowest, 1e-9);
    EXPECT_NEAR(high, highest, 1e-9);
  }
  EXPECT_GT(answered, 1000);
  EXPECT_GT(unanswered, 10);
}

TEST(SampleGround, IsTheColumnsPlaneAtItsCentreAndSmoothAround) {
  const SurfaceGraph& graph = Graph();
  const double h_ref = graph.params().reference_height_m;
  for (int node = 0; node < graph.node_count(); node += 41) {
    GroundSample s;
    ASSERT_TRUE(SampleGround(Scene(), graph.position(node), h_ref, 0, &s)) << node;
    EXPECT_EQ(s.surface, &graph.surface(node));
    EXPECT_NEAR(s.height_m, graph.surface(node).plane_center_z_m, 1e-6) << node;
  }
  const double h = 1e-6;
  int checked = 0;
  for (const Eigen::Vector3d& p : PointsNearNodes(200, 5)) {
    GroundSample s, plus, minus;
    if (!SampleGround(Scene(), p, h_ref, 5.0, &s)) continue;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step(axis) = h;
      ASSERT_TRUE(SampleGround(Scene(), p + step, h_ref, 5.0, &plus));
      ASSERT_TRUE(SampleGround(Scene(), p - step, h_ref, 5.0, &minus));
      EXPECT_NEAR(s.height_gradient(axis), (plus.height_m - minus.height_m) / (2 * h), 1e-5)
          << p.transpose() << " axis " << axis;
      EXPECT_NEAR(s.clearance_gradient(axis), (plus.clearance_m - minus.clearance_m) / (2 * h),
                  1e-4)
          << p.transpose() << " axis " << axis;
    }
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

}  // namespace
}  // namespace strata
