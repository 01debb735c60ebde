#pragma once
// What SurfaceGraph's build (surface_graph.cpp) and its patch (surface_graph_patch.cpp) share.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "strata/planning/surface_graph.hpp"

namespace strata::graph_internal {

// Nodes handled between two polls of should_stop.
inline constexpr int kNodesPerPoll = 4096;

// A landmark's distance to a node it does not reach.
inline constexpr float kUnreached = std::numeric_limits<float>::infinity();

// The cost of the move from a to b as the landmarks' tables add it (MoveCost under the default
// terms, in float): a table searched and a table updated (UpdateDistances) must add the same
// values to agree bit for bit.
inline float LandmarkMoveCost(const SurfaceGraph& graph, int a, int b) {
  return static_cast<float>(graph.MoveCost(a, b, MoveCostTerms{}));
}

// The rim distance a move from `a` to `b` adds on a grid of resolution `r` [m]: r along an
// axis, r√2 across, as float (the rim distances are sums of these).
inline float RimStep(const SurfaceGraph::Node& a, const SurfaceGraph::Node& b, double r) {
  return static_cast<float>(a.ix != b.ix && a.iy != b.iy ? std::sqrt(2.0) * r : r);
}

// Union-find over a graph's nodes in which each set's root is its first node, so that the
// labels come out numbered by each component's first node, as a search seeded in node order
// numbers them.
class NodeComponents {
 public:
  explicit NodeComponents(int nodes) : root_(static_cast<std::size_t>(nodes)) {
    std::iota(root_.begin(), root_.end(), 0);
  }
  void Join(std::int32_t a, std::int32_t b) {
    a = Find(a);
    b = Find(b);
    root_[std::max(a, b)] = std::min(a, b);
  }
  // Each node's component, in [0, *count).
  std::vector<std::int32_t> Labels(int* count) {
    std::vector<std::int32_t> labels(root_.size(), -1);
    *count = 0;
    for (std::size_t node = 0; node < root_.size(); ++node) {
      const std::int32_t first = Find(static_cast<std::int32_t>(node));
      labels[node] = first == static_cast<std::int32_t>(node) ? (*count)++ : labels[first];
    }
    return labels;
  }
  // The first node of `node`'s set.
  std::int32_t Find(std::int32_t node) {
    while (root_[node] != node) node = root_[node] = root_[root_[node]];  // Path halving.
    return node;
  }

 private:
  std::vector<std::int32_t> root_;
};

}  // namespace strata::graph_internal
