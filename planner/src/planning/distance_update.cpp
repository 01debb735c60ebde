// UpdateDistances: a landmark's distances after an edit, from its distances before.
#include "planning/distance_update.hpp"

#include <cstdint>
#include <functional>
#include <queue>
#include <utility>
#include <vector>

#include "planning/surface_graph_internal.hpp"

namespace strata::graph_internal {
namespace {

using Entry = std::pair<float, std::int32_t>;
using MinQueue = std::priority_queue<Entry, std::vector<Entry>, std::greater<>>;

}  // namespace

bool UpdateDistances(const SurfaceGraph& graph, int source, std::span<const std::int32_t> changed,
                     const std::function<bool()>& should_stop, std::vector<float>* distance) {
  const auto stopped = [&should_stop](int count) {
    return count % kNodesPerPoll == 0 && should_stop && should_stop();
  };
  std::vector<float>& d = *distance;
  const std::vector<float> before = d;
  d[source] = 0;

  // 1. Which values still stand. A value stands when a neighbour whose value stands gives it
  // exactly over today's move (so it is the cost of a path that exists now); a neighbour that
  // gives it has a smaller value (costs are positive), so the nodes are judged in the order
  // of their values: the changed nodes, then those a failed value may have given theirs. A node
  // never judged keeps its value: its moves and the path that gave it are as they were.
  enum : std::uint8_t { kUnjudged, kStands, kFails };
  std::vector<std::uint8_t> verdict(d.size(), kUnjudged);
  std::vector<std::int32_t> failed;
  MinQueue doubts;
  for (const std::int32_t node : changed) {
    if (before[node] < kUnreached) doubts.emplace(before[node], node);
  }
  for (int judged = 1; !doubts.empty(); ++judged) {
    if (stopped(judged)) return false;
    const std::int32_t node = doubts.top().second;
    doubts.pop();
    if (verdict[node] != kUnjudged) continue;
    bool stands = node == source;
    graph.ForEachNeighbor(node, [&](int from) {
      stands = stands || (verdict[from] != kFails && before[from] < before[node] &&
                          before[from] + LandmarkMoveCost(graph, from, node) == before[node]);
    });
    verdict[node] = stands ? kStands : kFails;
    if (stands) continue;
    d[node] = kUnreached;
    failed.push_back(node);
    graph.ForEachNeighbor(node, [&](int to) {
      if (verdict[to] == kUnjudged && before[to] > before[node] && before[to] < kUnreached) {
        doubts.emplace(before[to], to);
      }
    });
  }

  // 2. The search, from the failed nodes and the changed ones, each first given the least its
  // neighbours whose values stand offer over today's moves (a changed node's moves may now be
  // cheaper, or new, either way); from there it may improve any node.
  MinQueue queue;
  const auto seed = [&](std::int32_t node) {
    graph.ForEachNeighbor(node, [&](int from) {
      if (verdict[from] == kFails || !(d[from] < kUnreached)) return;
      const float reached = d[from] + LandmarkMoveCost(graph, from, node);
      if (reached < d[node]) d[node] = reached;
    });
    if (d[node] < kUnreached) queue.emplace(d[node], node);
  };
  for (const std::int32_t node : failed) seed(node);
  for (const std::int32_t node : changed) {
    if (verdict[node] != kFails) seed(node);
  }
  for (int popped = 1; !queue.empty(); ++popped) {
    if (stopped(popped)) return false;
    const float reached = queue.top().first;  // Not a structured binding: the lambda reads it.
    const std::int32_t node = queue.top().second;
    queue.pop();
    if (reached > d[node]) continue;
    graph.ForEachNeighbor(node, [&](int to) {
      const float next = reached + LandmarkMoveCost(graph, node, to);
      if (next < d[to]) {
        d[to] = next;
        queue.emplace(next, to);
      }
    });
  }
  return true;
}

}  // namespace strata::graph_internal
