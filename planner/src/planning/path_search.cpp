#include "strata/planning/path_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <queue>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "planning/search_state.hpp"

namespace strata {
Status SearchConfig::Validate(std::string_view path) const {
  const auto bad_config = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (max_expansions < 1) return bad_config("max_expansions", max_expansions, ">= 1");
  if (!(heuristic_weight >= 1 && heuristic_weight <= 3)) {
    return bad_config("heuristic_weight", heuristic_weight, "in [1, 3]");
  }
  if (!(line_bias >= 0 && line_bias <= 1)) return bad_config("line_bias", line_bias, "in [0, 1]");
  if (!(std::isfinite(clearance_weight) && clearance_weight >= 0)) {
    return bad_config("clearance_weight", clearance_weight, ">= 0 and finite");
  }
  if (!(std::isfinite(clearance_margin_m) && clearance_margin_m > 0)) {
    return bad_config("clearance_margin_m", clearance_margin_m, "> 0 and finite");
  }
  if (!(std::isfinite(rim_weight) && rim_weight >= 0)) {
    return bad_config("rim_weight", rim_weight, ">= 0 and finite");
  }
  if (!(std::isfinite(rim_margin_m) && rim_margin_m > 0 && rim_margin_m <= 1)) {
    return bad_config("rim_margin_m", rim_margin_m, "in (0, 1] m");
  }
  return Status::Ok();
}

Expected<PathResult> SearchPath(const SurfaceGraph& graph, int start_node, int goal_node,
                                const SearchConfig& config,
                                const std::function<bool()>& should_stop, SearchStats* stats,
                                const std::function<bool(int node)>& blocked) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  int expansions = 0;
  internal::SearchState state(graph.node_count());
  std::size_t reached = 0;
  const auto finish = [&]() {
    if (stats != nullptr) {
      stats->expansions = expansions;
      stats->reached_nodes = reached;
      stats->state_bytes = state.MemoryBytes();
      stats->elapsed_s = std::chrono::duration<double>(Clock::now() - t0).count();
    }
  };
  const auto fail = [&](ErrorCode code, std::string message) -> Expected<PathResult> {
    finish();
    return Error{code, std::move(message)};
  };

  if (Status s = config.Validate(); !s.ok()) {
    finish();
    return std::move(s).error();
  }
  const int n = graph.node_count();
  if (start_node < 0 || start_node >= n || goal_node < 0 || goal_node >= n) {
    return fail(
        ErrorCode::kInvalidInput,
        fmt::format("start node {} or goal node {} is outside [0, {})", start_node, goal_node, n));
  }
  const Eigen::Vector3d goal_p = graph.position(goal_node);
  const Eigen::Vector3d start_p = graph.position(start_node);
  if (graph.component(start_node) != graph.component(goal_node)) {
    // Which components, and how large, so that a viewer can show both (a linear count, only
    // on this failure path).
    const int start_component = graph.component(start_node);
    const int goal_component = graph.component(goal_node);
    std::size_t start_nodes = 0, goal_nodes = 0;
    for (int m = 0; m < n; ++m) {
      start_nodes += graph.component(m) == start_component ? 1 : 0;
      goal_nodes += graph.component(m) == goal_component ? 1 : 0;
    }
    finish();
    return Error{ErrorCode::kGoalUnreachable,
                 "goal " + internal::FormatPoint(goal_p) + " m is not connected to start " +
                     internal::FormatPoint(start_p) +
                     " m over traversable ground (they lie in different connected components)",
                 {},
                 {{"start_component", std::to_string(start_component)},
                  {"goal_component", std::to_string(goal_component)},
                  {"start_component_nodes", std::to_string(start_nodes)},
                  {"goal_component_nodes", std::to_string(goal_nodes)}}};
  }

  struct Entry {
    double f;
    double g;
    int node;
    bool operator>(const Entry& o) const { return f > o.f; }
  };
  // Moves cost the same both ways, so a search from the goal finds a path as cheap. Which way
  // floods less: SurfaceGraph::ShouldSearchBackward.
  const bool backward = graph.ShouldSearchBackward(start_node, goal_node, config);
  const int source = backward ? goal_node : start_node;
  const int target = backward ? start_node : goal_node;
  const Eigen::Vector3d target_p = graph.position(target);
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  state.At(source).g = 0;
  reached = 1;
  const double w = config.heuristic_weight;
  // SearchConfig::line_bias: the horizontal distance from the start–goal segment.
  const Eigen::Vector2d line_start = graph.position(source).head<2>();
  const Eigen::Vector2d line = target_p.head<2>() - line_start;
  const double line_squared = line.squaredNorm();
  const auto off_line = [&](int node) {
    const Eigen::Vector2d q = graph.position(node).head<2>() - line_start;
    const double t = line_squared > 0 ? std::clamp(q.dot(line) / line_squared, 0.0, 1.0) : 0.0;
    return config.line_bias * (q - t * line).norm();
  };
  // Only the straight line is weighted (SearchConfig::heuristic_weight).
  const auto heuristic = [&](int node) {
    return std::max(w * (graph.position(node) - target_p).norm(),
                    graph.LandmarkBound(node, target, config));
  };
  open.push({heuristic(source), 0.0, source});

  while (!open.empty()) {
    const Entry top = open.top();
    open.pop();
    internal::SearchState::Entry& top_state = state.At(top.node);
    if (top_state.closed || top.g > top_state.g) continue;  // Stale entry.
    if (top.node == target) {
      PathResult result;
      for (int v = target; v >= 0; v = state.At(v).parent) result.nodes.push_back(v);
      // The parent chain runs from the target back to the source: start to goal already
      // when the search ran backward.
      if (!backward) std::reverse(result.nodes.begin(), result.nodes.end());
      for (std::size_t i = 0; i < result.nodes.size(); ++i) {
        result.points_m.push_back(graph.position(result.nodes[i]));
        if (i > 0) result.length_m += (result.points_m[i] - result.points_m[i - 1]).norm();
      }
      result.cost = top_state.g;
      result.expansions = expansions;
      finish();
      return result;
    }
    if (expansions % 1024 == 0) {
      if (should_stop && should_stop()) {
        return fail(
            ErrorCode::kCancelled,
            fmt::format("search from {} m to {} m was cancelled after {} expansions",
                        internal::FormatPoint(start_p), internal::FormatPoint(goal_p), expansions));
      }
    }
    if (expansions >= config.max_expansions) {
      return fail(ErrorCode::kSearchBudgetExhausted,
                  fmt::format("search from {} m to {} m used its budget of {} expansions "
                              "(search.max_expansions) without reaching the goal",
                              internal::FormatPoint(start_p), internal::FormatPoint(goal_p),
                              config.max_expansions));
    }
    top_state.closed = true;
    ++expansions;
    graph.ForEachNeighbor(top.node, [&](int m) {
      internal::SearchState::Entry& next = state.At(m);
      if (next.closed) return;
      const double g = top.g + EdgeCost(graph, top.node, m, config);
      if (g < next.g) {
        // Checked only for a node about to improve: a blocked one never does, so it is asked
        // at most once per neighbour that reaches it.
        if (blocked && m != target && blocked(m)) return;
        reached += next.parent < 0;
        next.g = g;
        next.parent = top.node;
        open.push({g + heuristic(m) + off_line(m), g, m});
      }
    });
  }
  return fail(ErrorCode::kNoPath, fmt::format("no path found from {} m to {} m after {} expansions",
                                              internal::FormatPoint(start_p),
                                              internal::FormatPoint(goal_p), expansions));
}

}  // namespace strata
