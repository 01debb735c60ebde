// The terrain queries shared by the optimiser's costs and the final verification: exact at
// column centres, and their gradients match finite differences where the interpolation is
// smooth.
#include "strata/terrain_query.hpp"

#include <cmath>
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

TEST(SampleEdgeDistance, IsTheGraphsEdgeDistanceAtEveryNodeCentre) {
  const SurfaceGraph& graph = Graph();
  ASSERT_GT(graph.node_count(), 100);
  for (int node = 0; node < graph.node_count(); node += 37) {
    Eigen::Vector2d gradient;
    EXPECT_NEAR(SampleEdgeDistance(graph, graph.position(node), &gradient),
                graph.edge_distance(node), 1e-6)
        << node;
  }
}

TEST(SampleEdgeDistance, GradientMatchesFiniteDifferences) {
  const double h = 1e-6;
  int checked = 0;
  for (const Eigen::Vector3d& p : PointsNearNodes(200, 3)) {
    Eigen::Vector2d gradient, unused;
    SampleEdgeDistance(Graph(), p, &gradient);
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step(axis) = h;
      const double numeric = (SampleEdgeDistance(Graph(), p + step, &unused) -
                              SampleEdgeDistance(Graph(), p - step, &unused)) /
                             (2 * h);
      EXPECT_NEAR(gradient(axis), numeric, 1e-5) << p.transpose() << " axis " << axis;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 200);
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
