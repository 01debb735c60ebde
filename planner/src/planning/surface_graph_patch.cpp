// SurfaceGraph::Patch: the graph of an edited model, made from its base's graph by finding
// again only what the edit can change (see the declaration for what that is).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <queue>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "planning/surface_graph_internal.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {
namespace {

using graph_internal::kNodesPerPoll;

Error Cancelled() { return Error{ErrorCode::kCancelled, "patching the surface graph was stopped"}; }

bool SameGrid(const GridGeometry& a, const GridGeometry& b) {
  return a.size == b.size && a.origin_m == b.origin_m && a.resolution_m == b.resolution_m;
}

}  // namespace

Expected<SurfaceGraph> SurfaceGraph::Patch(const SurfaceGraph& base, const TerrainModel& model,
                                           const CellBox& changed_columns,
                                           const std::function<bool()>& should_stop) {
  const auto stopped = [&should_stop] { return should_stop && should_stop(); };
  const GridGeometry& g = model.grid();
  if (!SameGrid(g, base.grid())) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("the graph to patch lies on a grid of {} × {} × {} cells, the model "
                             "on one of {} × {} × {}: build the graph instead",
                             base.grid().size.x(), base.grid().size.y(), base.grid().size.z(),
                             g.size.x(), g.size.y(), g.size.z())};
  }
  if (Status s = CheckParams(model, base.params_); !s.ok()) return s.error();
  SurfaceGraph graph(model, base.params_);
  const Eigen::Vector3i one(1, 1, 0);
  CellBox changed = changed_columns;
  changed.min.z() = changed.max.z() = 0;
  // A node's clearance reads the fields of the next columns too (the interpolation), and its
  // moves and whether it lies on the rim read the next columns' nodes.
  const CellBox renewed = changed.empty() ? changed : changed.Grown(one, g);

  // 1. The nodes: those of the renewed columns found again, the rest (with their clearance and
  // rim distance) copied from the base, a row's run of columns at a time.
  const std::int64_t nx = g.size.x();
  graph.column_begin_.assign(static_cast<std::size_t>(g.LayerCellCount()) + 1, 0);
  // Room for a few more nodes per renewed column than the base holds (no column but a
  // multi-storey one has more), so that the arrays rarely grow.
  const std::size_t room = base.nodes_.size() + 4 * static_cast<std::size_t>(renewed.CellCount());
  graph.nodes_.reserve(room);
  graph.column_nodes_.reserve(room);
  graph.edge_distance_.reserve(room);
  const auto cap = static_cast<float>(EdgeDistanceCap(g.resolution_m));
  const auto copy_columns = [&](std::int64_t first, std::int64_t last) {  // [first, last)
    const std::uint32_t from = base.column_begin_[first], to = base.column_begin_[last];
    const auto shift = static_cast<std::int64_t>(graph.nodes_.size()) - from;
    for (std::uint32_t k = from; k < to; ++k) {
      graph.column_nodes_.push_back(static_cast<std::int32_t>(k + shift));
    }
    graph.nodes_.insert(graph.nodes_.end(), base.nodes_.begin() + from, base.nodes_.begin() + to);
    graph.edge_distance_.insert(graph.edge_distance_.end(), base.edge_distance_.begin() + from,
                                base.edge_distance_.begin() + to);
    for (std::int64_t c = first; c < last; ++c) {
      graph.column_begin_[c + 1] = static_cast<std::uint32_t>(base.column_begin_[c + 1] + shift);
    }
  };
  for (int iy = 0; iy < g.size.y(); ++iy) {
    if (stopped()) return Cancelled();
    const std::int64_t row = nx * iy;
    if (renewed.empty() || iy < renewed.min.y() || iy > renewed.max.y()) {
      copy_columns(row, row + nx);
      continue;
    }
    copy_columns(row, row + renewed.min.x());
    for (int ix = renewed.min.x(); ix <= renewed.max.x(); ++ix) {
      graph.AppendColumnNodes(ix, iy, /*measure_clearance=*/true);
      graph.edge_distance_.resize(graph.nodes_.size(), cap);
      graph.column_begin_[row + ix + 1] = static_cast<std::uint32_t>(graph.column_nodes_.size());
    }
    copy_columns(row + renewed.max.x() + 1, row + nx);
  }

  // 2. The components, over the whole graph: a diagonal move needs a node in each column it
  // passes between an axis step from both ends (the class comment), so the axis moves alone
  // join every pair of nodes a diagonal joins, and each axis move is taken once, from its
  // lower end. Numbered by each component's first node, as Build numbers them.
  const int n = graph.node_count();
  graph_internal::NodeComponents components(n);
  for (int node = 0; node < n; ++node) {
    if ((node + 1) % kNodesPerPoll == 0 && stopped()) return Cancelled();
    const auto join = [&](int m) { components.Join(node, m); };
    graph.ForEachNeighborToward(node, 1, 0, join);
    graph.ForEachNeighborToward(node, 0, 1, join);
  }
  graph.components_ = components.Labels(&graph.component_count_);
  graph.open_ground_clearance_m_ = graph.ClearanceTenthPercentile();

  // 3. The rim distances. A path shorter than the cap spans fewer than cap / r columns, so
  // outside `window` every node's distance is the base's: its paths to the rim and the rim
  // itself lie where nothing changed. Inside, the distances are found again from the rim
  // nodes inside and from the nodes just outside, whose distances hold (the last node outside
  // on any path from the rim). The search (Dijkstra; Build's queue takes only keys near the
  // last popped) reaches the same least values as Build's.
  const int reach = static_cast<int>(std::ceil(cap / g.resolution_m)) + 1;
  const CellBox window = renewed.empty() ? renewed : renewed.Grown({reach, reach, 0}, g);
  if (!renewed.empty()) {
    const CellBox border = window.Grown(one, g);
    using Entry = std::pair<float, std::int32_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    const auto rim_distance = static_cast<float>(0.5 * g.resolution_m);
    for (int iy = border.min.y(); iy <= border.max.y(); ++iy) {
      for (int ix = border.min.x(); ix <= border.max.x(); ++ix) {
        const bool inside = window.Contains({ix, iy, 0});
        for (const std::int32_t node : graph.ColumnNodes(ix, iy)) {
          float& d = graph.edge_distance_[node];
          if (inside) {
            int neighbours = 0;
            graph.ForEachNeighbor(node, [&](int) { ++neighbours; });
            d = neighbours < 8 ? rim_distance : cap;
          }
          if (d < cap) queue.emplace(d, node);
        }
      }
    }
    const double r = g.resolution_m;
    for (int popped = 1; !queue.empty(); ++popped) {
      if (popped % kNodesPerPoll == 0 && stopped()) return Cancelled();
      const float d = queue.top().first;
      const std::int32_t m = queue.top().second;
      queue.pop();
      if (d > graph.edge_distance_[m]) continue;
      const Node& a = graph.nodes_[m];
      graph.ForEachNeighbor(m, [&](int k) {
        const Node& b = graph.nodes_[k];
        if (!window.Contains({b.ix, b.iy, 0})) return;
        const float step = graph_internal::RimStep(a, b, r);
        if (d + step < graph.edge_distance_[k]) {
          graph.edge_distance_[k] = d + step;
          queue.emplace(graph.edge_distance_[k], k);
        }
      });
    }
  }

  // 4. The landmarks. Outside `window` the nodes and their rim distances are the base's.
  if (!graph.PatchLandmarks(base, window, should_stop)) return Cancelled();
  if (graph.nodes_.size() > room) {  // They grew, doubling: give back what is not used.
    graph.nodes_.shrink_to_fit();
    graph.column_nodes_.shrink_to_fit();
    graph.edge_distance_.shrink_to_fit();
  }
  return graph;
}

}  // namespace strata
