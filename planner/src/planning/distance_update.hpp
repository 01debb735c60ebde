#pragma once
// One landmark's distances on an edited graph, found from its distances on the graph before
// the edit (SurfaceGraph::Patch) instead of searched again over the whole graph.
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "strata/planning/surface_graph.hpp"

namespace strata::graph_internal {

// Turns *distance, given per node of `graph` as the least cost of a path from `source` on the
// graph before an edit (infinity for a node that graph lacked), into the least costs on
// `graph` (MoveCost under the default terms, summed in float as the landmarks' searches sum
// them; infinity where unreached). Every move the edit may have added, removed or re-costed
// must have both ends in `changed`. Dynamic shortest paths (in the
// spirit of Ramalingam and Reps, 1996): a value stands where a neighbour whose value stands still
// gives it exactly; the rest, and every improvement from the moves of `changed`, are found by a
// search that starts from where the values stand. The result is the least fixpoint the whole search
// reaches, bit for bit, at a cost that grows with the nodes whose values changed. False when
// should_stop (may be empty; polled every 4096 nodes) fired.
bool UpdateDistances(const SurfaceGraph& graph, int source, std::span<const std::int32_t> changed,
                     const std::function<bool()>& should_stop, std::vector<float>* distance);

}  // namespace strata::graph_internal
