#pragma once
/// Straightening the A* path before the optimiser sees it (string pulling inside the
/// traversable corridor). A path over an 8-connected grid zigzags and hugs the heuristic's
/// side; started from it, the optimiser keeps a gentle weave that the safety field holds in
/// place. Here each vertex is joined to the farthest later one that a straight line (in x, y,
/// following the ground from column to column) reaches over the surface graph as well as the
/// path did: every column it crosses has a node adjacent to the previous one, as far from the
/// rim and from obstacles as the search's margins ask (the clearance margin at most the
/// graph's open-ground clearance; near an end that is nearer, as near as that end, the
/// allowance shrinking back to the margin half a metre per metre away from it), outside the
/// request's keep-out zones. The result is a path over the same graph, cell by cell, so
/// it stays traversable by construction.
#include <functional>

#include "strata/planning/path_search.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {

/// Settings of ShortenPath.
struct ShorteningConfig {
  /// Longest stretch of path, measured along it, that one straight segment may replace [m],
  /// > 0. Longer ones add nothing on a straight stretch (their vertices are collinear) and
  /// cost a walk each.
  double max_segment_m = 12.0;
  /// Longer stretches, up to max_straight_segment_m, are tried where the path runs nearly
  /// straight: its ends at least straight_ratio of its length apart in x, y. An 8-connected
  /// path runs straight and diagonally with 45° bends between; windows of max_segment_m only
  /// round such a bend, and the trajectory turned there twice (abandoned_station's median
  /// curvature over 100 pairs 0.114 -> 0.104 with these defaults). A path that comes back on
  /// itself (the level above on a spiral) stops the window: those walks would fail.
  double straight_ratio = 0.9;
  double max_straight_segment_m = 60.0;  ///< [m], >= max_segment_m.
};

/// The straightened path from path.nodes.front() to path.nodes.back(): nodes cell by cell
/// along straight lines between pulled vertices, points_m their reference points, length_m
/// and cost (EdgeCost under `search`) recomputed, expansions kept. `blocked` (may be empty)
/// marks nodes the line must not cross, as in SearchPath. A path of fewer than three nodes is
/// returned as it is. Never longer than `path` in length: a segment is replaced only by a
/// straight line between its ends.
PathResult ShortenPath(const SurfaceGraph& graph, const PathResult& path,
                       const SearchConfig& search, const ShorteningConfig& config = {},
                       const std::function<bool(int node)>& blocked = {});

/// The nodes a straight line from node `from` to node `to` crosses, both included, walking
/// column by column (each step to an edge-adjacent column) over graph edges, each node meeting
/// accept(node); empty when the walk leaves the graph, changes level or a node fails accept.
std::vector<int> WalkStraight(const SurfaceGraph& graph, int from, int to,
                              const std::function<bool(int node)>& accept);

}  // namespace strata
