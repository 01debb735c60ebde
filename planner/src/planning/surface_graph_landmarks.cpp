// SurfaceGraph's landmarks (ALT), chosen and measured once per graph: see
// SurfaceGraph::LandmarkBound.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "planning/bucket_queue.hpp"
#include "planning/distance_update.hpp"
#include "planning/surface_graph_internal.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {
namespace {

using graph_internal::kUnreached;

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
  for (int node = 0; node < n; ++node) {
    edges.begin.push_back(static_cast<std::uint32_t>(edges.list.size()));
    if (graph.component(node) != component) continue;
    graph.ForEachNeighbor(node, [&](int m) {
      const float cost = graph_internal::LandmarkMoveCost(graph, node, m);
      edges.list.push_back({m, cost});
      edges.cheapest = std::min(edges.cheapest, cost);
      edges.dearest = std::max(edges.dearest, cost);
    });
  }
  edges.begin.push_back(static_cast<std::uint32_t>(edges.list.size()));
  return edges;
}

// Least costs of paths from `source` over `edges` to every node; kUnreached outside its
// component. False when should_stop fired (polled every kNodesPerPoll nodes settled).
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
    if (settled % graph_internal::kNodesPerPoll == 0 && should_stop && should_stop()) return false;
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

bool SurfaceGraph::ChooseLandmarks(const DistancesFrom& distances_from) {
  landmark_count_ = 0;
  landmark_distance_.clear();
  seed_distance_.clear();
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
  std::vector<float> distance;
  if (!distances_from(seed, &distance)) return false;
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
    if (!distances_from(next, &table)) return false;
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
  seed_distance_ = std::move(distance);
  return true;
}

bool SurfaceGraph::ComputeLandmarks(const std::function<bool()>& should_stop) {
  std::optional<CostedEdges> edges;  // Of the landmarks' component, costed at the first search.
  return ChooseLandmarks([&](int source, std::vector<float>* distance) {
    if (!edges) edges = EdgesOf(*this, components_[source]);
    return Distances(*edges, source, should_stop, distance);
  });
}

bool SurfaceGraph::PatchLandmarks(const SurfaceGraph& base, const CellBox& changed_columns,
                                  const std::function<bool()>& should_stop) {
  if (base.landmark_count_ == 0) return ComputeLandmarks(should_stop);
  // Each node's counterpart in the base: in every column with as many nodes, in their order.
  const GridGeometry& g = grid();
  const int n = node_count();
  std::vector<std::int32_t> base_node(static_cast<std::size_t>(n), -1);
  std::vector<std::int32_t> new_node(static_cast<std::size_t>(base.node_count()), -1);
  for (int iy = 0; iy < g.size.y(); ++iy) {
    for (int ix = 0; ix < g.size.x(); ++ix) {
      const NodeRange now = ColumnNodes(ix, iy);
      const NodeRange then = base.ColumnNodes(ix, iy);
      if (now.size() != then.size()) continue;
      for (std::size_t k = 0; k < now.size(); ++k) {
        base_node[now[k]] = then[k];
        new_node[then[k]] = now[k];
      }
    }
  }
  // The columns of `changed_columns` whose nodes differ from the base's (in number, or in what
  // a move reads of them: height, clearance, rim distance), and the nodes of those and the
  // next: a move reads its ends and the columns it passes between, all next to both ends, so
  // every move that changed has both ends among them.
  const auto differs = [&](int ix, int iy) {
    const NodeRange now = ColumnNodes(ix, iy);
    const NodeRange then = base.ColumnNodes(ix, iy);
    if (now.size() != then.size()) return true;
    for (std::size_t k = 0; k < now.size(); ++k) {
      const Node& a = nodes_[now[k]];
      const Node& b = base.nodes_[then[k]];
      if (a.reference_z_m != b.reference_z_m || a.clearance_m != b.clearance_m ||
          edge_distance_[now[k]] != base.edge_distance_[then[k]]) {
        return true;
      }
    }
    return false;
  };
  std::vector<std::int32_t> changed;
  if (!changed_columns.empty()) {
    const CellBox box = changed_columns.Grown({1, 1, 0}, g);
    const int width = box.max.x() - box.min.x() + 1;
    const auto at = [&](int ix, int iy) {
      return static_cast<std::size_t>(ix - box.min.x()) +
             static_cast<std::size_t>(iy - box.min.y()) * width;
    };
    std::vector<std::uint8_t> near(static_cast<std::size_t>(width) *
                                   (box.max.y() - box.min.y() + 1));
    for (int iy = changed_columns.min.y(); iy <= changed_columns.max.y(); ++iy) {
      for (int ix = changed_columns.min.x(); ix <= changed_columns.max.x(); ++ix) {
        if (!differs(ix, iy)) continue;
        for (int y = std::max(iy - 1, box.min.y()); y <= std::min(iy + 1, box.max.y()); ++y) {
          for (int x = std::max(ix - 1, box.min.x()); x <= std::min(ix + 1, box.max.x()); ++x) {
            near[at(x, y)] = 1;
          }
        }
      }
    }
    for (int iy = box.min.y(); iy <= box.max.y(); ++iy) {
      for (int ix = box.min.x(); ix <= box.max.x(); ++ix) {
        if (!near[at(ix, iy)]) continue;
        const NodeRange nodes = ColumnNodes(ix, iy);
        changed.insert(changed.end(), nodes.begin(), nodes.end());
      }
    }
  }
  // The base's tables by the node each is measured from (its one node at distance 0): its
  // landmarks' and, when it has them, its seed's.
  struct Table {
    const float* values;  // Of base node m at values[m * stride].
    std::size_t stride;
    std::int32_t source = -1;  // Here.
    float At(std::int32_t m) const { return values[static_cast<std::size_t>(m) * stride]; }
  };
  std::vector<Table> known;
  const auto add = [&](Table table) {
    for (std::int32_t m = 0; m < base.node_count() && table.source < 0; ++m) {
      if (table.At(m) == 0) table.source = new_node[m];
    }
    known.push_back(table);
  };
  const auto count = static_cast<std::size_t>(base.landmark_count_);
  for (std::size_t k = 0; k < count; ++k) add({base.landmark_distance_.data() + k, count});
  if (!base.seed_distance_.empty()) add({base.seed_distance_.data(), 1});
  std::optional<CostedEdges> edges;  // For a landmark the base had no table of.
  return ChooseLandmarks([&](int source, std::vector<float>* distance) {
    for (const Table& table : known) {
      if (table.source != source) continue;
      distance->resize(static_cast<std::size_t>(n));
      for (int m = 0; m < n; ++m) {
        (*distance)[m] = base_node[m] < 0 ? kUnreached : table.At(base_node[m]);
      }
      return graph_internal::UpdateDistances(*this, source, changed, should_stop, distance);
    }
    if (!edges) edges = EdgesOf(*this, components_[source]);
    return Distances(*edges, source, should_stop, distance);
  });
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
