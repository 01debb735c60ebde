#pragma once
// Random start/goal pairs for benchmarks: both ends are nodes of the largest connected
// component of a robot's SurfaceGraph, so every pair is valid and reachable for Strata; the
// same seed gives the same pairs.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "strata/planning/surface_graph.hpp"

namespace strata::bench {

/// The nodes of the graph's largest connected component (the lowest label among equals).
struct LargestComponent {
  int label = -1;          ///< Component label, -1 for an empty graph.
  std::vector<int> nodes;  ///< Its nodes, ascending.
};
LargestComponent FindLargestComponent(const SurfaceGraph& graph);

/// A query: reference points of two nodes [m].
struct QueryPair {
  Eigen::Vector3d start_m;
  Eigen::Vector3d goal_m;
};

/// `count` pairs drawn uniformly (std::mt19937 seeded with `seed`, start then goal) from the
/// largest component's nodes. A goal closer than min_separation_m (straight line) to its start
/// is drawn again, up to 100 times (then kept). Empty for an empty graph.
std::vector<QueryPair> DrawQueryPairs(const SurfaceGraph& graph, int count, std::uint32_t seed,
                                      double min_separation_m = 0);

}  // namespace strata::bench
