#pragma once
/// Front end of the planner: A* over the near-surface cells of a SurfaceGraph (26-connected,
/// clearance-aware cost, the admissible heuristic max(straight line weighted by
/// heuristic_weight, SurfaceGraph::LandmarkBound), plus a small bias towards the straight
/// start–goal line),
/// with an expansion budget and a should_stop callable for deadlines and cancellation. Every
/// failure names its reason.

#include <functional>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/planning/surface_graph.hpp"
#include "strata/status.hpp"

namespace strata {

/// A* settings. Validate() blames the first bad field by its path, `path`.<field>. The
/// move-cost terms (clearance and rim) are MoveCostTerms'.
struct SearchConfig : MoveCostTerms {
  /// Most nodes the search may expand [-], >= 1. Reaching it fails with
  /// kSearchBudgetExhausted.
  int max_expansions = 2'000'000;
  /// Factor w on the straight-line part of the heuristic [-], in [1, 3]: A* expands
  /// f = g + max(w·‖p − p_goal‖, SurfaceGraph::LandmarkBound), and the path found costs at
  /// most w times the cheapest (weighted A*). 1 is plain A*, optimal. The cost's clearance and
  /// rim terms make the cheapest path cost more than the straight line, so plain A* explores a
  /// wide ellipse around it (docs/benchmarks.md, "Why the planner's defaults"). The landmark
  /// bound is not weighted: it already bounds the cost, clearance and rim terms included, and
  /// weighted it would trade the path's cost for speed where it is tight.
  double heuristic_weight = 1.05;
  /// Weight of a node's horizontal distance from the straight start–goal segment, added to its
  /// priority [-], in [0, 1]. Over a grid many paths round a small obstacle cost alike (an
  /// 8-connected path's length does not see which side is shorter in a straight line); this
  /// keeps the search on the side nearest that line, which shortening (path_shortening.hpp)
  /// then pulls straighter: on uneven_terrain's random pairs the trajectories' median
  /// curvature fell by a fifth. The path found costs at most heuristic_weight times the
  /// cheapest plus line_bias times the largest such distance of a node it expanded.
  double line_bias = 0.05;

  Status Validate(std::string_view path = "search") const;
};

/// A path over graph nodes.
struct PathResult {
  std::vector<Eigen::Vector3d> points_m;  ///< Reference points, start to goal [m].
  std::vector<int> nodes;                 ///< The graph nodes of points_m.
  double length_m = 0;                    ///< Euclidean 3D length of the polyline [m].
  double cost = 0;                        ///< Sum of EdgeCost along the path [m].
  int expansions = 0;                     ///< Nodes expanded by the search [-].
};

/// Work done by a search, filled on success and failure alike.
struct SearchStats {
  int expansions = 0;             ///< Nodes expanded [-].
  std::size_t reached_nodes = 0;  ///< Nodes given a cost (expanded or on the frontier) [-].
  std::size_t state_bytes = 0;    ///< Memory of the per-node search state [B], ∝ reached_nodes.
  double elapsed_s = 0;           ///< Wall-clock time [s].
};

/// Cost of moving between adjacent nodes a and b: SurfaceGraph::MoveCost under the config's
/// terms. Never below the length, so the straight line is an admissible heuristic, and so is
/// SurfaceGraph::LandmarkBound under these terms. Inline: the search calls it for every edge.
inline double EdgeCost(const SurfaceGraph& graph, int a, int b, const SearchConfig& config) {
  return graph.MoveCost(a, b, config);
}

/// Cheapest path from start_node to goal_node (e.g. SnapResult::node). Fails with:
/// kInvalidConfig (bad config), kInvalidInput (node out of range), kGoalUnreachable (the
/// nodes are in different components; decided before any expansion), kCancelled
/// (should_stop returned true), kSearchBudgetExhausted (max_expansions reached), kNoPath (open
/// set emptied; defensive). The search has no clock of its own: should_stop, checked before
/// the first expansion and every 1024 after, is how a caller bounds it in time (Plan passes
/// its deadline and reports kDeadlineExceeded itself). `should_stop` may be empty. `stats`,
/// when non-null, receives the work done. `blocked` (may be empty) keeps nodes out of the
/// search for this call only, leaving the shared graph as it is (Plan passes the keep-out
/// zones): a node for which it returns true is never reached, except the start and the goal.
/// When it cuts the goal off, the search ends with kNoPath (the components do not know it).
/// Where the landmarks say it floods less (SurfaceGraph::ShouldSearchBackward), the search
/// runs from the goal back to the start; the path is returned from start to goal either way.
Expected<PathResult> SearchPath(const SurfaceGraph& graph, int start_node, int goal_node,
                                const SearchConfig& config,
                                const std::function<bool()>& should_stop,
                                SearchStats* stats = nullptr,
                                const std::function<bool(int node)>& blocked = {});

}  // namespace strata
