#include "strata/planning/path_shortening.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace strata {

std::vector<int> WalkStraight(const SurfaceGraph& graph, int from, int to,
                              const std::function<bool(int node)>& accept) {
  if (!accept(from)) return {};
  const Eigen::Vector2i delta = graph.column(to) - graph.column(from);
  const int steps_x = std::abs(delta.x()), steps_y = std::abs(delta.y());
  const int sign_x = delta.x() > 0 ? 1 : -1, sign_y = delta.y() > 0 ? 1 : -1;
  std::vector<int> nodes = {from};
  nodes.reserve(static_cast<std::size_t>(steps_x) + static_cast<std::size_t>(steps_y) + 1);
  int node = from;
  // The line from centre to centre crosses the k-th column edge in x at parameter
  // (k + 1/2) / steps_x, in y at (k + 1/2) / steps_y: step along whichever comes first,
  // compared in integers. A line through a corner steps in x first: both columns beside the
  // corner must then be walkable, which is the stricter choice.
  for (int kx = 0, ky = 0; kx < steps_x || ky < steps_y;) {
    const bool step_x =
        ky >= steps_y || (kx < steps_x && (2 * kx + 1) * steps_y <= (2 * ky + 1) * steps_x);
    (step_x ? kx : ky) += 1;
    // The neighbour in the next column; of two within a step (rare), the nearer in height.
    int next = -1;
    double gap = std::numeric_limits<double>::infinity();
    const double z = graph.position(node).z();
    graph.ForEachNeighborToward(node, step_x ? sign_x : 0, step_x ? 0 : sign_y, [&](int m) {
      const double g = std::abs(graph.position(m).z() - z);
      if (g < gap) {
        gap = g;
        next = m;
      }
    });
    if (next < 0 || !accept(next)) return {};
    nodes.push_back(next);
    node = next;
  }
  if (node != to) return {};  // Arrived at another level of the goal's column.
  return nodes;
}

namespace {

// How fast the rim and obstacle allowance of a tight end grows back, per metre travelled
// from it (ShortenPath).
constexpr double kAllowanceSlope = 0.5;

// How far below the graph's open-ground clearance (a tenth of the nodes are nearer an
// obstacle) open ground itself may lie [m]: the obstacle distance of open ground varies by a
// few millimetres from column to column (0.108-0.110 m for the biped on indoor_tables), and
// a cap at the percentile itself failed a straight line across open floor at a node 1 mm
// under it, leaving the line's bend to the trajectory.
constexpr double kOpenGroundClearanceSpreadM = 0.01;

// Vertices tried from the farthest inwards before the vertex-by-vertex scan (ShortenPath).
constexpr std::size_t kFarCandidates = 8;

// Tightening passes over the pulled vertices at most (ShortenPath); each usually removes a
// few, and a pass that removes none ends them.
constexpr int kTighteningPasses = 4;

// EdgeCost per metre between two adjacent nodes (>= 1).
double CostFactor(const SurfaceGraph& graph, int a, int b, const SearchConfig& search) {
  const double length = (graph.position(a) - graph.position(b)).norm();
  return length > 0 ? EdgeCost(graph, a, b, search) / length : 1.0;
}

// The straight line from walk.front() to walk.back() through the walk's columns: each node's
// point is the foot of its column centre on the line (in x, y), at the node's height.
// Calls visit(node, point) for every node after the first.
template <typename Visit>
void ForEachLinePoint(const SurfaceGraph& graph, const std::vector<int>& walk, Visit&& visit) {
  const Eigen::Vector3d a = graph.position(walk.front());
  const Eigen::Vector2d direction = (graph.position(walk.back()) - a).head<2>();
  const double squared = direction.squaredNorm();
  for (std::size_t k = 1; k < walk.size(); ++k) {
    const Eigen::Vector3d centre = graph.position(walk[k]);
    const double t =
        squared > 0 ? std::clamp((centre - a).head<2>().dot(direction) / squared, 0.0, 1.0) : 0;
    Eigen::Vector3d p;
    p << a.head<2>() + t * direction, centre.z();
    visit(walk[k], p);
  }
}

// The search's cost of driving the line through the walk's columns: each step's length times
// the EdgeCost per metre between its nodes.
double LineCost(const SurfaceGraph& graph, const std::vector<int>& walk,
                const SearchConfig& search) {
  double cost = 0;
  Eigen::Vector3d previous = graph.position(walk.front());
  int previous_node = walk.front();
  ForEachLinePoint(graph, walk, [&](int node, const Eigen::Vector3d& p) {
    cost += (p - previous).norm() * CostFactor(graph, previous_node, node, search);
    previous = p;
    previous_node = node;
  });
  return cost;
}

// Appends the line through `walk` to *out (without its first node).
void AppendStraight(const SurfaceGraph& graph, const std::vector<int>& walk,
                    const SearchConfig& search, PathResult* out) {
  ForEachLinePoint(graph, walk, [&](int node, const Eigen::Vector3d& p) {
    const double step = (p - out->points_m.back()).norm();
    out->length_m += step;
    out->cost += step * CostFactor(graph, out->nodes.back(), node, search);
    out->nodes.push_back(node);
    out->points_m.push_back(p);
  });
}

// Whether a stretch of path from a to b, `along_m` long measured along it, is one a line may
// replace (ShorteningConfig).
bool SegmentCandidate(const SurfaceGraph& graph, int a, int b, double along_m,
                      const ShorteningConfig& config) {
  if (along_m <= config.max_segment_m) return true;
  return along_m <= config.max_straight_segment_m &&
         (graph.position(b) - graph.position(a)).head<2>().norm() >=
             config.straight_ratio * along_m;
}

// A walk of a straight line (empty when refused) and its LineCost.
struct Line {
  std::vector<int> walk;
  double cost;
};

}  // namespace

PathResult ShortenPath(const SurfaceGraph& graph, const PathResult& path,
                       const SearchConfig& search, const ShorteningConfig& config,
                       const std::function<bool(int node)>& blocked) {
  const std::vector<int>& nodes = path.nodes;
  const std::size_t n = nodes.size();
  if (n < 3) return path;
  std::vector<double> along(n, 0.0);      // Arc length of the path up to each node [m].
  std::vector<double> path_cost(n, 0.0);  // Its EdgeCost up to each node.
  for (std::size_t k = 1; k < n; ++k) {
    along[k] = along[k - 1] + (graph.position(nodes[k]) - graph.position(nodes[k - 1])).norm();
    path_cost[k] = path_cost[k - 1] + EdgeCost(graph, nodes[k - 1], nodes[k], search);
  }
  const double r = graph.grid().resolution_m;
  // The line from node a to node b: its walk and LineCost, the walk empty when it leaves the
  // graph, crosses a blocked node, passes nearer the rim than one and a half cells or nearer
  // an obstacle than the search's margin, or costs more than `budget` in the search's own
  // terms. Where an end is nearer (the path squeezed past a corner there), the line may be as
  // near at that end, the allowance growing back at half the distance travelled from it: a
  // line may leave a tight spot, not run along the rim from it. The margin is capped just
  // under the graph's open-ground clearance (kOpenGroundClearanceSpreadM): where the ground
  // itself is nearer the reference point than the margin, a margin no path keeps would forbid
  // every line longer than a few cells.
  const double clearance_margin = std::min(
      search.clearance_margin_m, graph.open_ground_clearance_m() - kOpenGroundClearanceSpreadM);
  const auto line = [&](int a, int b, double budget) {
    const Eigen::Vector2d pa = graph.position(a).head<2>(), pb = graph.position(b).head<2>();
    const double rim_a = graph.edge_distance(a), rim_b = graph.edge_distance(b);
    const double clear_a = graph.clearance(a), clear_b = graph.clearance(b);
    std::vector<int> walk = WalkStraight(graph, a, b, [&](int m) {
      const Eigen::Vector2d p = graph.position(m).head<2>();
      const double from_a = kAllowanceSlope * (p - pa).norm();
      const double from_b = kAllowanceSlope * (p - pb).norm();
      const double rim_floor = std::min({1.5 * r, rim_a + from_a, rim_b + from_b});
      const double clearance_floor =
          std::min({clearance_margin, clear_a + from_a, clear_b + from_b});
      return graph.edge_distance(m) >= rim_floor && graph.clearance(m) >= clearance_floor &&
             !(blocked && m != nodes.front() && m != nodes.back() && blocked(m));
    });
    Line result{std::move(walk), 0};
    if (!result.walk.empty()) result.cost = LineCost(graph, result.walk, search);
    if (result.cost > budget + 1e-9) result.walk.clear();
    return result;
  };

  // 1. Pull: from each vertex, the farthest later node of the path within the window
  // (SegmentCandidate) that a line reaches for no more than the path's cost between them; a
  // few candidates from the farthest inwards (a line that fails halfway may pass farther on,
  // past an obstacle's edge), then, if none passes, node by node from the nearest until one
  // fails.
  std::vector<int> vertices = {nodes.front()};
  std::vector<double> vertex_cost = {0};  // Cost of the shortened path up to each vertex.
  std::size_t i = 0;
  while (i + 1 < n) {
    std::size_t last = i + 1;
    while (last + 1 < n &&
           SegmentCandidate(graph, nodes[i], nodes[last + 1], along[last + 1] - along[i], config)) {
      ++last;
    }
    std::size_t reached = i + 1;
    double reached_cost = path_cost[i + 1] - path_cost[i];
    const std::size_t stride = std::max<std::size_t>(1, (last - i) / kFarCandidates);
    const auto try_line = [&](std::size_t j) {
      const Line l = line(nodes[i], nodes[j], path_cost[j] - path_cost[i]);
      if (l.walk.empty()) return false;
      reached = j;
      reached_cost = l.cost;
      return true;
    };
    for (std::size_t j = last; j >= i + 2 && reached == i + 1; j = j >= stride ? j - stride : 0) {
      try_line(j);
      if (j < stride) break;
    }
    for (std::size_t j = reached + 1; j <= last && stride > 1; ++j) {
      if (!try_line(j)) break;
    }
    vertices.push_back(nodes[reached]);
    vertex_cost.push_back(vertex_cost.back() + reached_cost);
    i = reached;
  }

  // 2. Tighten: the pull is greedy, so a later pass over its vertices still finds lines that
  // skip some, for no more than the pulled path's cost between their ends. As in the pull,
  // only vertices within the window along the path are tried: those nearer in a straight
  // line but farther along (the level above on a spiral, the far side of a bend) were walks
  // that almost always failed, and on the spiral's long queries half of the shortening's time.
  for (int pass = 0; pass < kTighteningPasses; ++pass) {
    std::vector<double> vertex_along(vertices.size(), 0.0);  // Along the pulled path [m].
    for (std::size_t k = 1; k < vertices.size(); ++k) {
      vertex_along[k] = vertex_along[k - 1] +
                        (graph.position(vertices[k]) - graph.position(vertices[k - 1])).norm();
    }
    std::vector<int> tight = {vertices.front()};
    std::vector<double> tight_cost = {0};
    bool removed = false;
    for (std::size_t a = 0; a + 1 < vertices.size();) {
      std::size_t c = a + 1;
      double cost = vertex_cost[a + 1] - vertex_cost[a];
      std::size_t last = a + 1;
      while (last + 1 < vertices.size() &&
             SegmentCandidate(graph, vertices[a], vertices[last + 1],
                              vertex_along[last + 1] - vertex_along[a], config)) {
        ++last;
      }
      for (std::size_t j = last; j >= a + 2; --j) {
        const Line l = line(vertices[a], vertices[j], vertex_cost[j] - vertex_cost[a]);
        if (l.walk.empty()) continue;
        c = j;
        cost = l.cost;
        removed = true;
        break;
      }
      tight.push_back(vertices[c]);
      tight_cost.push_back(tight_cost.back() + cost);
      a = c;
    }
    vertices = std::move(tight);
    vertex_cost = std::move(tight_cost);
    if (!removed) break;
  }

  // 3. The path: the lines between consecutive vertices, column by column.
  PathResult out;
  out.expansions = path.expansions;
  out.nodes = {vertices.front()};
  out.points_m = {graph.position(vertices.front())};
  for (std::size_t k = 1; k < vertices.size(); ++k) {
    std::vector<int> walk =
        line(vertices[k - 1], vertices[k], std::numeric_limits<double>::infinity()).walk;
    if (walk.empty()) {  // Adjacent path nodes: always walkable.
      walk = {vertices[k - 1], vertices[k]};
    }
    AppendStraight(graph, walk, search, &out);
  }
  return out;
}

}  // namespace strata
