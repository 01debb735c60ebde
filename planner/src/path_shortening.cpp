#include "strata/path_shortening.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace strata {

std::vector<int> WalkStraight(const SurfaceGraph& graph, int from, int to,
                              const std::function<bool(int node)>& accept) {
  if (!accept(from)) return {};
  const Eigen::Vector2i start = graph.column(from);
  const Eigen::Vector2i delta = graph.column(to) - start;
  const int steps_x = std::abs(delta.x()), steps_y = std::abs(delta.y());
  const int sign_x = delta.x() > 0 ? 1 : -1, sign_y = delta.y() > 0 ? 1 : -1;
  std::vector<int> nodes = {from};
  nodes.reserve(static_cast<std::size_t>(steps_x + steps_y + 1));
  Eigen::Vector2i cell = start;
  int node = from;
  // The line from centre to centre crosses the k-th column edge in x at parameter
  // (k + 1/2) / steps_x, in y at (k + 1/2) / steps_y: step along whichever comes first,
  // compared in integers. A line through a corner steps in x first: both columns beside the
  // corner must then be walkable, which is the stricter choice.
  for (int kx = 0, ky = 0; kx < steps_x || ky < steps_y;) {
    const bool step_x =
        ky >= steps_y || (kx < steps_x && (2 * kx + 1) * steps_y <= (2 * ky + 1) * steps_x);
    if (step_x) {
      cell.x() += sign_x;
      ++kx;
    } else {
      cell.y() += sign_y;
      ++ky;
    }
    // The neighbour in that column; of two within a step (rare), the nearer in height.
    int next = -1;
    double gap = std::numeric_limits<double>::infinity();
    const double z = graph.position(node).z();
    graph.ForEachNeighbor(node, [&](int m) {
      if (graph.column(m) != cell) return;
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

// How fast the rim and obstacle allowance of a tight end grows back to the margin, per metre
// travelled from it (ShortenPath).
constexpr double kAllowanceSlope = 0.5;

// Vertices tried from the farthest inwards before the vertex-by-vertex scan (ShortenPath).
constexpr std::size_t kFarCandidates = 8;

// EdgeCost per metre between two adjacent nodes (>= 1).
double CostFactor(const SurfaceGraph& graph, int a, int b, const SearchConfig& search) {
  const double length = (graph.position(a) - graph.position(b)).norm();
  return length > 0 ? EdgeCost(graph, a, b, search) / length : 1.0;
}

// Appends the walk from `walk.front()` to `walk.back()` to *out (without its first node),
// each node's point the foot of its column centre on the straight line, at the node's height.
void AppendStraight(const SurfaceGraph& graph, const std::vector<int>& walk,
                    const SearchConfig& search, PathResult* out) {
  const Eigen::Vector3d a = graph.position(walk.front());
  const Eigen::Vector2d direction = (graph.position(walk.back()) - a).head<2>();
  const double squared = direction.squaredNorm();
  for (std::size_t k = 1; k < walk.size(); ++k) {
    const Eigen::Vector3d centre = graph.position(walk[k]);
    const double t =
        squared > 0 ? std::clamp((centre - a).head<2>().dot(direction) / squared, 0.0, 1.0) : 0;
    Eigen::Vector3d p;
    p << a.head<2>() + t * direction, centre.z();
    const double step = (p - out->points_m.back()).norm();
    out->length_m += step;
    out->cost += step * CostFactor(graph, out->nodes.back(), walk[k], search);
    out->nodes.push_back(walk[k]);
    out->points_m.push_back(p);
  }
}

}  // namespace

PathResult ShortenPath(const SurfaceGraph& graph, const PathResult& path,
                       const SearchConfig& search, const ShorteningConfig& config,
                       const std::function<bool(int node)>& blocked) {
  const std::vector<int>& nodes = path.nodes;
  const std::size_t n = nodes.size();
  if (n < 3) return path;
  std::vector<double> along(n, 0.0);  // Arc length of the path up to each node [m].
  for (std::size_t k = 1; k < n; ++k) {
    along[k] = along[k - 1] + (graph.position(nodes[k]) - graph.position(nodes[k - 1])).norm();
  }

  PathResult out;
  out.expansions = path.expansions;
  out.nodes = {nodes.front()};
  out.points_m = {graph.position(nodes.front())};
  const auto walk_line = [&](std::size_t i, std::size_t j) {
    // The line keeps the search's margins from the rim and from obstacles. Where an end is
    // nearer (the path squeezed past a corner there), the line may be as near at that end,
    // the allowance shrinking back to the margin at half the distance travelled from it: a
    // line may leave a tight spot, not run along the rim from it.
    const Eigen::Vector3d a = graph.position(nodes[i]), b = graph.position(nodes[j]);
    const double rim_a = graph.edge_distance(nodes[i]), rim_b = graph.edge_distance(nodes[j]);
    const double clear_a = graph.clearance(nodes[i]), clear_b = graph.clearance(nodes[j]);
    return WalkStraight(graph, nodes[i], nodes[j], [&](int m) {
      const Eigen::Vector3d p = graph.position(m);
      const double from_a = kAllowanceSlope * (p - a).head<2>().norm();
      const double from_b = kAllowanceSlope * (p - b).head<2>().norm();
      const double rim = std::min({search.rim_margin_m, rim_a + from_a, rim_b + from_b});
      const double clearance =
          std::min({search.clearance_margin_m, clear_a + from_a, clear_b + from_b});
      return graph.edge_distance(m) >= rim && graph.clearance(m) >= clearance &&
             !(blocked && m != nodes.front() && m != nodes.back() && blocked(m));
    });
  };
  std::size_t i = 0;
  while (i + 1 < n) {
    // The farthest vertex within reach: a few candidates from the farthest inwards (a line
    // that fails halfway may pass farther on, past the obstacle's edge), then, if none
    // passes, vertex by vertex from the nearest until one fails.
    std::size_t last = i + 1;
    while (last + 1 < n && along[last + 1] - along[i] <= config.max_segment_m) ++last;
    std::size_t reached = i + 1;
    std::vector<int> walk = {nodes[i], nodes[i + 1]};
    const std::size_t stride = std::max<std::size_t>(1, (last - i) / kFarCandidates);
    for (std::size_t j = last; j >= i + 2 && reached == i + 1; j = j >= stride ? j - stride : 0) {
      if (std::vector<int> line = walk_line(i, j); !line.empty()) {
        walk = std::move(line);
        reached = j;
      }
      if (j < stride) break;
    }
    for (std::size_t j = reached + 1; j <= last && stride > 1; ++j) {
      std::vector<int> line = walk_line(i, j);
      if (line.empty()) break;
      walk = std::move(line);
      reached = j;
    }
    AppendStraight(graph, walk, search, &out);
    i = reached;
  }
  return out;
}

}  // namespace strata
