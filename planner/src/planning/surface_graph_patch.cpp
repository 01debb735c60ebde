// SurfaceGraph::Patch: the graph of an edited model, made from its base's graph by finding
// again only what the edit can change (see the declaration for what that is).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <queue>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "planning/clearance_ranks.hpp"
#include "planning/surface_graph_internal.hpp"
#include "prefault_internal.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {
namespace {

using graph_internal::kNodesPerPoll;

// How far around the renewed columns a patch looks for the moves that keep a component joined
// without them [columns], each tried in turn: the ground around a pallet joins within a few;
// a deck whose ramp lies tens of metres away needs the wider rings. The widest (about 1.1 M
// columns) takes tens of milliseconds on a site, where labelling the whole graph takes 0.3-1 s.
constexpr int kJoinedRingColumns[] = {16, 128, 512};

// The four axis directions: axis moves alone join every pair of nodes a diagonal joins (the
// class comment), so they alone decide the components.
constexpr int kAxisSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};

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
  // Room for a few more nodes per renewed column than the base holds (no column but a
  // multi-storey one has more), so that the arrays rarely grow.
  const std::size_t room = base.nodes_.size() + 4 * static_cast<std::size_t>(renewed.CellCount());
  graph.nodes_.reserve(room);
  graph.edge_distance_.reserve(room);
  graph.components_.reserve(room);
  graph.column_begin_.reserve(base.column_begin_.size());
  graph.column_begin_.push_back(0);
  const auto cap = static_cast<float>(EdgeDistanceCap(g.resolution_m));
  // Without ranks of its own, the base's clearances are counted around its 10th percentile as
  // they are copied: they give the patched graph's (step 2).
  std::optional<graph_internal::ClearanceRanks> counted;
  if (!base.open_ranks_) counted.emplace(static_cast<float>(base.open_ground_clearance_m_));
  // The base's components go with its nodes, for step 2 (-1 for the renewed nodes).
  const auto copy_columns = [&](std::int64_t first, std::int64_t last) {  // [first, last)
    const std::uint32_t from = base.column_begin_[first], to = base.column_begin_[last];
    const auto shift = static_cast<std::int64_t>(graph.nodes_.size()) - from;
    if (counted) counted->Add(std::span(base.nodes_).subspan(from, to - from));
    graph.nodes_.insert(graph.nodes_.end(), base.nodes_.begin() + from, base.nodes_.begin() + to);
    graph.edge_distance_.insert(graph.edge_distance_.end(), base.edge_distance_.begin() + from,
                                base.edge_distance_.begin() + to);
    graph.components_.insert(graph.components_.end(), base.components_.begin() + from,
                             base.components_.begin() + to);
    for (std::int64_t c = first; c < last; ++c) {
      graph.column_begin_.push_back(static_cast<std::uint32_t>(base.column_begin_[c + 1] + shift));
    }
  };
  // The arrays are filled on this thread; their pages are faulted in on another.
  const std::array<internal::PageRegion, 4> filled = {
      internal::CapacityOf(graph.nodes_), internal::CapacityOf(graph.edge_distance_),
      internal::CapacityOf(graph.components_), internal::CapacityOf(graph.column_begin_)};
  const bool copied = internal::FillWithPagesFaultedAhead(filled, [&] {
    for (int iy = 0; iy < g.size.y(); ++iy) {
      if (stopped()) return false;
      const std::int64_t row = nx * iy;
      if (renewed.empty() || iy < renewed.min.y() || iy > renewed.max.y()) {
        copy_columns(row, row + nx);
      } else {
        copy_columns(row, row + renewed.min.x());
        for (int ix = renewed.min.x(); ix <= renewed.max.x(); ++ix) {
          const std::size_t column_first_node = graph.nodes_.size();
          graph.AppendColumnNodes(ix, iy, /*measure_clearance=*/true);
          if (counted) counted->Add(std::span(graph.nodes_).subspan(column_first_node));
          graph.edge_distance_.resize(graph.nodes_.size(), cap);
          graph.components_.resize(graph.nodes_.size(), -1);
          graph.column_begin_.push_back(static_cast<std::uint32_t>(graph.nodes_.size()));
        }
        copy_columns(row + renewed.max.x() + 1, row + nx);
      }
    }
    return true;
  });
  if (!copied) return Cancelled();

  // 2. The components, numbered by each component's first node, as Build numbers them: from
  // the base's, where PiecesWithout tells the parts the components the edit touched fall into
  // without the renewed columns (near them: a pallet on open ground, a deck whose ramp is
  // renewed), joined again across the renewed nodes; else over the whole graph, each axis move
  // taken once, from its lower end.
  const int n = graph.node_count();
  std::vector<std::vector<std::int32_t>> pieces;
  if (base.PiecesWithout(renewed, &pieces)) {
    if (!graph.LabelComponentsAcross(base, renewed, pieces, stopped)) return Cancelled();
  } else {
    graph_internal::NodeComponents components(n);
    for (int node = 0; node < n; ++node) {
      if ((node + 1) % kNodesPerPoll == 0 && stopped()) return Cancelled();
      const auto join = [&](int m) { components.Join(node, m); };
      graph.ForEachNeighborToward(node, 1, 0, join);
      graph.ForEachNeighborToward(node, 0, 1, join);
    }
    graph.components_ = components.Labels(&graph.component_count_);
  }
  graph.PatchOpenGroundClearance(base, renewed, counted ? &*counted : nullptr);

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
    graph.edge_distance_.shrink_to_fit();
  }
  return graph;
}

bool SurfaceGraph::PiecesWithout(const CellBox& columns,
                                 std::vector<std::vector<std::int32_t>>* pieces) const {
  pieces->clear();
  if (columns.empty()) return true;
  for (const int ring_columns : kJoinedRingColumns) {
    if (PiecesWithinRing(columns, ring_columns, pieces)) return true;
    const CellBox window = columns.Grown({ring_columns, ring_columns, 0}, grid());
    if (window.size().head<2>() == grid().size.head<2>()) break;  // No wider ring to try.
  }
  return false;
}

bool SurfaceGraph::PiecesWithinRing(const CellBox& columns, int ring_columns,
                                    std::vector<std::vector<std::int32_t>>* pieces) const {
  // The ring: the nodes of the window around `columns` but theirs, joined by their moves within
  // it. A window row's nodes are consecutive (nodes are numbered column by column, x fastest),
  // so a node's place in the window's numbering is its row's first place plus its offset.
  const GridGeometry& g = grid();
  const CellBox window = columns.Grown({ring_columns, ring_columns, 0}, g);
  const auto column_index = [&g](int ix, int iy) { return ix + std::int64_t{g.size.x()} * iy; };
  std::vector<std::int64_t> row_first(static_cast<std::size_t>(window.size().y()) + 1, 0);
  for (int iy = window.min.y(); iy <= window.max.y(); ++iy) {
    const std::size_t r = static_cast<std::size_t>(iy - window.min.y());
    row_first[r + 1] = row_first[r] + column_begin_[column_index(window.max.x(), iy) + 1] -
                       column_begin_[column_index(window.min.x(), iy)];
  }
  const auto in_ring = [&](int node) -> std::int32_t {  // Its place, or -1 outside the ring.
    const Node& m = nodes_[node];
    const Eigen::Vector3i c(m.ix, m.iy, 0);
    if (!window.Contains(c) || columns.Contains(c)) return -1;
    const auto r = static_cast<std::size_t>(m.iy - window.min.y());
    return static_cast<std::int32_t>(row_first[r] + node -
                                     column_begin_[column_index(window.min.x(), m.iy)]);
  };
  // Calls f(node, place) for every node of the ring.
  const auto for_each_ring_node = [&](const auto& f) {
    for (int iy = window.min.y(); iy <= window.max.y(); ++iy) {
      for (int ix = window.min.x(); ix <= window.max.x(); ++ix) {
        if (columns.Contains({ix, iy, 0})) continue;
        for (const std::int32_t node : ColumnNodes(ix, iy)) f(node, in_ring(node));
      }
    }
  };
  graph_internal::NodeComponents joined(static_cast<int>(row_first.back()));
  for_each_ring_node([&](std::int32_t node, std::int32_t i) {
    const auto join = [&](int m) {
      if (const std::int32_t j = in_ring(m); j >= 0) joined.Join(i, j);
    };
    ForEachNeighborToward(node, 1, 0, join);
    ForEachNeighborToward(node, 0, 1, join);
  });
  // A set is open when it reaches the window's edge where the grid goes on: it may go on
  // outside the window.
  std::vector<bool> open(static_cast<std::size_t>(row_first.back()), false);
  const auto at_open_edge = [&](const Node& m) {
    return (m.ix == window.min.x() && m.ix > 0) ||
           (m.ix == window.max.x() && m.ix < g.size.x() - 1) ||
           (m.iy == window.min.y() && m.iy > 0) ||
           (m.iy == window.max.y() && m.iy < g.size.y() - 1);
  };
  for_each_ring_node([&](std::int32_t node, std::int32_t i) {
    if (at_open_edge(nodes_[node])) open[static_cast<std::size_t>(joined.Find(i))] = true;
  });
  // The sets of nodes a move away from `columns`, with their component.
  std::vector<std::pair<std::int32_t, std::int32_t>> touching;  // (component, set)
  for (int iy = columns.min.y(); iy <= columns.max.y(); ++iy) {
    for (int ix = columns.min.x(); ix <= columns.max.x(); ++ix) {
      for (const std::int32_t node : ColumnNodes(ix, iy)) {
        for (const auto& step : kAxisSteps) {
          ForEachNeighborToward(node, step[0], step[1], [&](int m) {
            if (const std::int32_t j = in_ring(m); j >= 0) {
              touching.emplace_back(components_[m], joined.Find(j));
            }
          });
        }
      }
    }
  }
  std::sort(touching.begin(), touching.end());
  touching.erase(std::unique(touching.begin(), touching.end()), touching.end());
  // A component the columns touch keeps its label on the open set it touches, with all its
  // nodes outside the window (each reaches the columns through an open set, there being one);
  // each closed set it touches is a piece of its own. Two open sets may or may not meet
  // outside the window: then a wider ring is needed.
  std::unordered_map<std::int32_t, std::size_t> piece_of_set;
  std::int32_t last_open_component = -1;  // `touching` lists a component's sets together.
  for (const auto& [component, set] : touching) {
    if (open[static_cast<std::size_t>(set)]) {
      if (component == last_open_component) return false;
      last_open_component = component;
    } else {
      piece_of_set.emplace(set, piece_of_set.size());
    }
  }
  pieces->assign(piece_of_set.size(), {});
  if (!piece_of_set.empty()) {
    for_each_ring_node([&](std::int32_t node, std::int32_t i) {
      const auto it = piece_of_set.find(joined.Find(i));
      if (it != piece_of_set.end()) (*pieces)[it->second].push_back(node);
    });
  }
  return true;
}

bool SurfaceGraph::LabelComponentsAcross(const SurfaceGraph& base, const CellBox& renewed,
                                         const std::vector<std::vector<std::int32_t>>& pieces,
                                         const std::function<bool()>& stopped) {
  // The sets: the base's components, the pieces the renewed columns leave apart (each node
  // numbered here as in the base: the columns outside `renewed` are the base's), then each
  // renewed node; joined by every move of a renewed node.
  std::int32_t sets = base.component_count_;
  const std::int64_t nx = grid().size.x();
  for (const std::vector<std::int32_t>& piece : pieces) {
    for (const std::int32_t base_node : piece) {
      const Node& m = base.nodes_[base_node];
      const std::int64_t c = m.ix + nx * m.iy;
      components_[column_begin_[c] + (base_node - base.column_begin_[c])] = sets;
    }
    ++sets;
  }
  std::vector<std::int32_t> renewed_nodes;
  for (int iy = renewed.min.y(); iy <= renewed.max.y(); ++iy) {
    for (int ix = renewed.min.x(); ix <= renewed.max.x(); ++ix) {
      for (const std::int32_t node : ColumnNodes(ix, iy)) {
        components_[node] = sets++;
        renewed_nodes.push_back(node);
      }
    }
  }
  graph_internal::NodeComponents joined(sets);
  for (const std::int32_t node : renewed_nodes) {
    for (const auto& step : kAxisSteps) {
      ForEachNeighborToward(node, step[0], step[1],
                            [&](int m) { joined.Join(components_[node], components_[m]); });
    }
  }
  // Numbered in node order; a run of nodes of one set is looked up once.
  std::vector<std::int32_t> label(static_cast<std::size_t>(sets), -1);
  int count = 0;
  std::int32_t last_set = -1, last_label = -1;
  for (std::size_t node = 0; node < components_.size(); ++node) {
    if ((node + 1) % kNodesPerPoll == 0 && stopped()) return false;
    std::int32_t& c = components_[node];
    if (c != last_set) {
      last_set = c;
      std::int32_t& l = label[static_cast<std::size_t>(joined.Find(c))];
      if (l < 0) l = count++;
      last_label = l;
    }
    c = last_label;
  }
  component_count_ = count;
  return true;
}

void SurfaceGraph::PatchOpenGroundClearance(const SurfaceGraph& base, const CellBox& renewed,
                                            graph_internal::ClearanceRanks* counted) {
  if (nodes_.empty()) {
    open_ground_clearance_m_ = 0;
    open_ranks_ = nullptr;
    return;
  }
  std::optional<graph_internal::ClearanceRanks> ranks;
  if (counted != nullptr) {
    counted->Finish();
    ranks.emplace(std::move(*counted));
  } else if (base.open_ranks_) {
    // Only the renewed columns' nodes changed: outside them the nodes are the base's.
    std::vector<float> removed, added;
    if (!renewed.empty()) {
      for (int iy = renewed.min.y(); iy <= renewed.max.y(); ++iy) {
        for (int ix = renewed.min.x(); ix <= renewed.max.x(); ++ix) {
          for (const std::int32_t m : base.ColumnNodes(ix, iy)) {
            removed.push_back(base.nodes_[m].clearance_m);
          }
          for (const std::int32_t m : ColumnNodes(ix, iy)) added.push_back(nodes_[m].clearance_m);
        }
      }
    }
    ranks.emplace(*base.open_ranks_);
    ranks->Update(removed, added);
  }
  // The value at rank n / 10 in ascending order, as ClearanceTenthPercentile finds it.
  std::optional<float> open = ranks ? ranks->AtRank(nodes_.size() / 10) : std::nullopt;
  if (!open) {  // Too far from where the ranks were counted: counted again around the value.
    open = static_cast<float>(ClearanceTenthPercentile());
    ranks.emplace(*open);
    ranks->Add(nodes_);
    ranks->Finish();
  }
  open_ground_clearance_m_ = *open;
  open_ranks_ = std::make_shared<const graph_internal::ClearanceRanks>(std::move(*ranks));
}

std::size_t SurfaceGraph::OpenRanksBytes() const {
  return open_ranks_ ? open_ranks_->MemoryBytes() : 0;
}

}  // namespace strata
