// SurfaceGraph's landmarks (ALT), chosen and measured once per graph: see
// SurfaceGraph::LandmarkBound.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

#include "planning/bucket_queue.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {
namespace {

constexpr float kUnreached = std::numeric_limits<float>::infinity();

// The edges from the nodes of one component and what each costs (MoveCost under the default
// MoveCostTerms), as float: every landmark's search walks them, and finding a node's
// neighbours (the step and corner rules) and costing each move took most of a search's time.
struct CostedEdges {
  std::vector<std::uint32_t> begin;  // Per node and one past: its first edge.
  struct Edge {
    std::int32_t to;
    float cost;
  };
  std::vector<Edge> list;  // Each with its cost beside it: a step reads one cache line.
  float cheapest = std::numeric_limits<float>::infinity();  // Of the costs.
  float dearest = 0;
};

CostedEdges EdgesOf(const SurfaceGraph& graph, int component) {
  const int n = graph.node_count();
  CostedEdges edges;
  edges.begin.reserve(static_cast<std::size_t>(n) + 1);
  const MoveCostTerms terms;
  for (int node = 0; node < n; ++node) {
    edges.begin.push_back(static_cast<std::uint32_t>(edges.list.size()));
    if (graph.component(node) != component) continue;
    graph.ForEachNeighbor(node, [&](int m) {
      const auto cost = static_cast<float>(graph.MoveCost(node, m, terms));
      edges.list.push_back({m, cost});
      edges.cheapest = std::min(edges.cheapest, cost);
      edges.dearest = std::max(edges.dearest, cost);
    });
  }
  edges.begin.push_back(static_cast<std::uint32_t>(edges.list.size()));
  return edges;
}

// Least costs of paths from `source` over `edges` to every node; kUnreached outside its
// component. False when should_stop fired (polled every 4096 nodes settled).
bool Distances(const CostedEdges& edges, int source, const std::function<bool()>& should_stop,
               std::vector<float>* distance) {
  distance->assign(edges.begin.size() - 1, kUnreached);
  (*distance)[source] = 0;
  if (edges.list.empty()) return true;
  graph_internal::BucketQueue queue(edges.cheapest, edges.dearest);
  queue.Push(0.0f, source);
  float d = 0;
  std::int32_t node = 0;
  for (int settled = 1; queue.Pop(&d, &node); ++settled) {
    if (settled % 4096 == 0 && should_stop && should_stop()) return false;
    if (d > (*distance)[node]) continue;
    for (std::uint32_t e = edges.begin[node]; e < edges.begin[node + 1]; ++e) {
      const float next = d + edges.list[e].cost;
      const int m = edges.list[e].to;
      if (next < (*distance)[m]) {
        (*distance)[m] = next;
        queue.Push(next, m);
      }
    }
  }
  return true;
}

}  // namespace

bool SurfaceGraph::ComputeLandmarks(const std::function<bool()>& should_stop) {
  landmark_count_ = 0;
  landmark_distance_.clear();
  const int n = node_count();
  if (n == 0 || n > kMaxLandmarkNodes) return true;
  // The largest component: where long searches and detours are.
  std::vector<int> sizes(static_cast<std::size_t>(component_count_), 0);
  for (const std::int32_t c : components_) ++sizes[c];
  const int largest =
      static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  if (sizes[largest] < 2) return true;
  int seed = 0;
  while (components_[seed] != largest) ++seed;

  // Farthest-point selection: the first landmark is the node farthest from an arbitrary one,
  // each next the node farthest from every landmark so far (the periphery, where the bounds
  // are tightest).
  const CostedEdges edges = EdgesOf(*this, largest);
  std::vector<float> distance;
  if (!Distances(edges, seed, should_stop, &distance)) return false;
  std::vector<float> nearest_landmark(static_cast<std::size_t>(n), kUnreached);
  std::vector<std::vector<float>> tables;
  int next = seed;
  for (int k = 0; k < kMaxLandmarks; ++k) {
    float farthest = -1;
    const std::vector<float>& from = tables.empty() ? distance : nearest_landmark;
    for (int m = 0; m < n; ++m) {
      if (components_[m] == largest && from[m] > farthest) {
        farthest = from[m];
        next = m;
      }
    }
    if (farthest <= 0) break;  // Every node is a landmark already (a tiny component).
    std::vector<float> table;
    if (!Distances(edges, next, should_stop, &table)) return false;
    for (int m = 0; m < n; ++m) nearest_landmark[m] = std::min(nearest_landmark[m], table[m]);
    tables.push_back(std::move(table));
  }
  landmark_count_ = static_cast<int>(tables.size());
  landmark_distance_.resize(static_cast<std::size_t>(n) * landmark_count_);
  for (int m = 0; m < n; ++m) {
    for (int k = 0; k < landmark_count_; ++k) {
      landmark_distance_[static_cast<std::size_t>(m) * landmark_count_ + k] = tables[k][m];
    }
  }
  return true;
}

bool SurfaceGraph::ShouldSearchBackward(int start, int goal, const MoveCostTerms& terms) const {
  if (LandmarkBound(start, goal, terms) <= 0) return false;
  const float* ls = &landmark_distance_[static_cast<std::size_t>(start) * landmark_count_];
  const float* lg = &landmark_distance_[static_cast<std::size_t>(goal) * landmark_count_];
  double nearer_start = 0, nearer_goal = 0;  // The largest bound from landmarks on each side.
  for (int k = 0; k < landmark_count_; ++k) {
    const double gap = double{lg[k]} - double{ls[k]};
    if (gap > 0) {
      nearer_start = std::max(nearer_start, gap);
    } else {
      nearer_goal = std::max(nearer_goal, -gap);
    }
  }
  return nearer_start > nearer_goal;
}

}  // namespace strata
