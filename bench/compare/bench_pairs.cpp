#include "compare/bench_pairs.hpp"

#include <algorithm>
#include <random>

namespace strata::bench {

LargestComponent FindLargestComponent(const SurfaceGraph& graph) {
  LargestComponent result;
  if (graph.node_count() == 0) return result;
  std::vector<int> size(static_cast<std::size_t>(graph.component_count()), 0);
  for (int m = 0; m < graph.node_count(); ++m) ++size[graph.component(m)];
  result.label = static_cast<int>(std::max_element(size.begin(), size.end()) - size.begin());
  for (int m = 0; m < graph.node_count(); ++m) {
    if (graph.component(m) == result.label) result.nodes.push_back(m);
  }
  return result;
}

std::vector<QueryPair> DrawQueryPairs(const SurfaceGraph& graph, int count, std::uint32_t seed,
                                      double min_separation_m) {
  const LargestComponent component = FindLargestComponent(graph);
  std::vector<QueryPair> pairs;
  if (component.nodes.empty()) return pairs;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, component.nodes.size() - 1);
  for (int k = 0; k < count; ++k) {
    QueryPair pair;
    pair.start_m = graph.position(component.nodes[pick(rng)]);
    pair.goal_m = graph.position(component.nodes[pick(rng)]);
    for (int retry = 0; retry < 100 && (pair.goal_m - pair.start_m).norm() < min_separation_m;
         ++retry) {
      pair.goal_m = graph.position(component.nodes[pick(rng)]);
    }
    pairs.push_back(pair);
  }
  return pairs;
}

}  // namespace strata::bench
