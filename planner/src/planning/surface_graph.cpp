#include "strata/planning/surface_graph.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "planning/bucket_queue.hpp"
#include "planning/surface_graph_internal.hpp"

namespace strata {
namespace {

using graph_internal::kNodesPerPoll;

Error Cancelled() { return Error{ErrorCode::kCancelled, "building the surface graph was stopped"}; }

/// Calls visit(node) for the nodes of the grid's columns around column `c`, ring by ring (ring
/// k: the columns k cells away along x or y, at least (k - 1) cells from `c`'s cell), up to
/// `max_ring`, and stops before a ring when done(ring) says so. Only columns inside the grid
/// are visited, so a ring costs at most the grid's side even far from it.
template <typename Done, typename Visit>
void VisitRings(const SurfaceGraph& graph, const Eigen::Vector3i& c, int max_ring, Done&& done,
                Visit&& visit) {
  const Eigen::Vector3i& size = graph.grid().size;
  for (int ring = 0; ring <= max_ring && !done(ring); ++ring) {
    const int dy_low = std::max(-ring, -c.y());
    const int dy_high = std::min(ring, size.y() - 1 - c.y());
    for (int dy = dy_low; dy <= dy_high; ++dy) {
      const auto visit_column = [&](int dx) {
        for (const std::int32_t m : graph.ColumnNodes(c.x() + dx, c.y() + dy)) visit(m);
      };
      if (std::abs(dy) == ring) {
        const int dx_high = std::min(ring, size.x() - 1 - c.x());
        for (int dx = std::max(-ring, -c.x()); dx <= dx_high; ++dx) visit_column(dx);
      } else {
        visit_column(-ring);
        visit_column(ring);
      }
    }
  }
}

}  // namespace

Status SurfaceGraph::CheckParams(const TerrainModel& model, const TraversabilityParams& params) {
  if (Status s = params.Validate(); !s.ok()) return s;
  const double map_tilt = model.config().ground.max_tilt_rad;
  if (params.max_tilt_rad > map_tilt) {
    return Error{ErrorCode::kInvalidConfig,
                 fmt::format("traversability.max_tilt_rad = {:g} exceeds the map's ground "
                             "filter ground.max_tilt_rad = {:g}: steeper ground was never "
                             "marked valid",
                             params.max_tilt_rad, map_tilt),
                 "traversability.max_tilt_rad"};
  }
  return Status::Ok();
}

SurfaceGraph::SurfaceGraph(const TerrainModel& model, const TraversabilityParams& params)
    : model_(&model), params_(params) {
  const double slope = std::tan(params.max_tilt_rad) * model.grid().resolution_m;
  step_limit_axis_ = static_cast<float>(params.max_step_m + slope);
  step_limit_diagonal_ = static_cast<float>(params.max_step_m + std::sqrt(2.0) * slope);
}

bool SurfaceGraph::CollectNodes(const std::function<bool()>& stopped, bool measure_clearance) {
  const GridGeometry& g = model_->grid();
  column_begin_.assign(static_cast<std::size_t>(g.LayerCellCount()) + 1, 0);
  for (int iy = 0; iy < g.size.y(); ++iy) {
    if (stopped()) return false;
    for (int ix = 0; ix < g.size.x(); ++ix) {
      AppendColumnNodes(ix, iy, measure_clearance);
      column_begin_[ix + std::int64_t{g.size.x()} * iy + 1] =
          static_cast<std::uint32_t>(nodes_.size());
    }
  }
  return true;
}

void SurfaceGraph::AppendColumnNodes(int ix, int iy, bool measure_clearance) {
  const TerrainModel& model = *model_;
  const GridGeometry& g = model.grid();
  const double z_min = g.origin_m.z();
  const double z_max = z_min + g.size.z() * g.resolution_m;
  const std::span<const ColumnSurface> column = model.surfaces().Column(ix, iy);
  int level = 0;
  for (std::size_t k = 0; k < column.size(); ++k) {
    const ColumnSurface& s = column[k];
    if (!s.valid) continue;
    const int this_level = level++;
    const double reference_z = s.ground_z_m + params_.reference_height_m;
    if (s.tilt_rad > params_.max_tilt_rad || s.clearance_m < params_.body_height_m ||
        reference_z < z_min || reference_z >= z_max) {
      continue;
    }
    const Eigen::Vector3d p(g.origin_m.x() + (ix + 0.5) * g.resolution_m,
                            g.origin_m.y() + (iy + 0.5) * g.resolution_m, reference_z);
    nodes_.push_back(Node{ix, iy, static_cast<std::int16_t>(k),
                          static_cast<std::int16_t>(this_level), static_cast<float>(reference_z),
                          measure_clearance ? static_cast<float>(model.Distance(p)) : 0.0f});
  }
}

double SurfaceGraph::ClearanceTenthPercentile() const {
  if (nodes_.empty()) return 0;
  std::vector<float> clearances(nodes_.size());
  for (std::size_t k = 0; k < clearances.size(); ++k) clearances[k] = nodes_[k].clearance_m;
  const auto tenth = clearances.begin() + static_cast<std::ptrdiff_t>(clearances.size() / 10);
  std::nth_element(clearances.begin(), tenth, clearances.end());
  return *tenth;
}

Expected<SurfaceGraph> SurfaceGraph::FromParts(const TerrainModel& model, Parts parts) {
  if (Status s = CheckParams(model, parts.params); !s.ok()) return s.error();
  SurfaceGraph graph(model, parts.params);
  // The parts' size is what a right graph has (their arrays came from a file of that size):
  // reserved, the node arrays grow without copies.
  graph.nodes_.reserve(parts.clearance_m.size());
  graph.CollectNodes([] { return false; }, /*measure_clearance=*/false);
  const std::size_t n = graph.nodes_.size();
  const auto fail = [](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, "the graph does not fit the model: " + what};
  };
  if (parts.clearance_m.size() != n || parts.components.size() != n ||
      parts.edge_distance_m.size() != n) {
    return fail(fmt::format("it has {} nodes where the model and the robot's parameters give {}",
                            parts.clearance_m.size(), n));
  }
  if (parts.component_count < 0 || static_cast<std::size_t>(parts.component_count) > n) {
    return fail(fmt::format("{} components for {} nodes", parts.component_count, n));
  }
  if (parts.landmark_count < 0 || parts.landmark_count > kMaxLandmarks ||
      parts.landmark_distance.size() != n * static_cast<std::size_t>(parts.landmark_count)) {
    return fail(fmt::format("{} landmarks with {} distances for {} nodes", parts.landmark_count,
                            parts.landmark_distance.size(), n));
  }
  if (!std::isfinite(parts.open_ground_clearance_m)) return fail("a non-finite clearance");
  for (std::size_t k = 0; k < n; ++k) {
    if (parts.components[k] < 0 || parts.components[k] >= parts.component_count) {
      return fail(fmt::format("node {} has component {} of {}", k, parts.components[k],
                              parts.component_count));
    }
    if (!std::isfinite(parts.clearance_m[k]) || !std::isfinite(parts.edge_distance_m[k]) ||
        parts.edge_distance_m[k] < 0) {
      return fail(fmt::format("node {} has a clearance or rim distance out of range", k));
    }
    graph.nodes_[k].clearance_m = parts.clearance_m[k];
  }
  for (const float d : parts.landmark_distance) {
    if (std::isnan(d) || d < 0) return fail("a landmark distance out of range");
  }
  graph.components_ = std::move(parts.components);
  graph.component_count_ = parts.component_count;
  graph.edge_distance_ = std::move(parts.edge_distance_m);
  graph.open_ground_clearance_m_ = parts.open_ground_clearance_m;
  graph.landmark_count_ = parts.landmark_count;
  graph.landmark_distance_ = std::move(parts.landmark_distance);
  return graph;
}

Expected<SurfaceGraph> SurfaceGraph::Build(const TerrainModel& model,
                                           const TraversabilityParams& params,
                                           const std::function<bool()>& should_stop) {
  const auto stopped = [&should_stop] { return should_stop && should_stop(); };
  if (Status s = CheckParams(model, params); !s.ok()) return s.error();

  SurfaceGraph graph(model, params);
  if (!graph.CollectNodes(stopped, /*measure_clearance=*/true)) return Cancelled();

  // Component labels: the edges joined by union-find in one pass over the nodes in their
  // order (a breadth-first search's scattered visits took 1.6 times as long on a site), then
  // numbered by each component's first node, as a search seeded in node order numbers them.
  // The same pass finds the rim: the nodes missing one of their 8 neighbours.
  const int n = graph.node_count();
  graph_internal::NodeComponents components(n);
  std::vector<std::int32_t> rim;
  for (int node = 0; node < n; ++node) {
    if ((node + 1) % kNodesPerPoll == 0 && stopped()) return Cancelled();
    int neighbours = 0;
    graph.ForEachNeighbor(node, [&](int m) {
      ++neighbours;
      if (m > node) components.Join(node, m);  // Each edge once.
    });
    if (neighbours < 8) rim.push_back(node);
  }
  graph.components_ = components.Labels(&graph.component_count_);
  graph.open_ground_clearance_m_ = graph.ClearanceTenthPercentile();
  if (!graph.ComputeEdgeDistances(rim, should_stop)) return Cancelled();
  if (!graph.ComputeLandmarks(should_stop)) return Cancelled();
  // The node arrays grew by push_back: give back what they reserved beyond their size.
  graph.nodes_.shrink_to_fit();
  return graph;
}

bool SurfaceGraph::ComputeEdgeDistances(const std::vector<std::int32_t>& rim,
                                        const std::function<bool()>& should_stop) {
  // Multi-source Dijkstra over the graph's own edges (lengths r and r√2) from the rim nodes: a
  // chamfer distance, within 8% of Euclidean, cheap and exact at the rim. It stops at the
  // cap, so it visits only the band of nodes within the cap of a rim.
  const double r = grid().resolution_m;
  const auto cap = static_cast<float>(EdgeDistanceCap(r));
  edge_distance_.assign(static_cast<std::size_t>(node_count()), cap);
  graph_internal::BucketQueue queue(static_cast<float>(r), static_cast<float>(std::sqrt(2.0) * r));
  for (const std::int32_t m : rim) {
    edge_distance_[m] = static_cast<float>(0.5 * r);
    queue.Push(edge_distance_[m], m);
  }
  float d = 0;
  std::int32_t m = 0;
  for (int popped = 1; queue.Pop(&d, &m); ++popped) {
    if (popped % kNodesPerPoll == 0 && should_stop && should_stop()) return false;
    if (d > edge_distance_[m]) continue;
    const Node& a = nodes_[m];
    ForEachNeighbor(m, [&](int k) {
      const float step = graph_internal::RimStep(a, nodes_[k], r);
      if (d + step < edge_distance_[k]) {
        edge_distance_[k] = d + step;
        queue.Push(edge_distance_[k], k);
      }
    });
  }
  return true;
}

int SurfaceGraph::NodeNear(int ix, int iy, double ground_z) const {
  int best = -1;
  double best_gap = kLevelGapM;
  for (const std::int32_t m : ColumnNodes(ix, iy)) {
    const double gap = std::abs(SurfaceGraph::ground_z(m) - ground_z);
    if (gap <= best_gap) {
      best_gap = gap;
      best = m;
    }
  }
  return best;
}

int SurfaceGraph::NodeNear(int ix, int iy, double height, double* low, double* high) const {
  const int best = NodeNear(ix, iy, height);
  *low = 0;
  *high = 0;
  if (best < 0) return best;
  // The node stays the nearest up to the midpoints to its neighbours in height and within
  // kLevelGapM of its own. The band is shrunk by far more than the rounding of the gaps
  // NodeNear compares, so that it never claims a height where a tie could go the other way.
  constexpr double kRoundingM = 1e-6;
  const double own = SurfaceGraph::ground_z(best);
  *low = own - kLevelGapM;
  *high = own + kLevelGapM;
  for (const std::int32_t m : ColumnNodes(ix, iy)) {
    const double other = SurfaceGraph::ground_z(m);
    if (m == best) continue;
    if (other <= own) *low = std::max(*low, 0.5 * (own + other));
    if (other >= own) *high = std::min(*high, 0.5 * (own + other));
  }
  *low += kRoundingM;
  *high -= kRoundingM;
  return best;
}

Expected<SnapResult> SnapToSurface(const SurfaceGraph& graph, const Eigen::Vector3d& p,
                                   double tolerance_m, ErrorCode off_ground_code,
                                   const std::function<bool(int node)>& accept,
                                   std::string_view refusal) {
  const char* what = off_ground_code == ErrorCode::kStartOffGround  ? "start"
                     : off_ground_code == ErrorCode::kGoalOffGround ? "goal"
                                                                    : "point";
  if (!p.allFinite()) {
    return Error{ErrorCode::kInvalidInput,
                 std::string(what) + " " + internal::FormatPoint(p) + " m is not finite"};
  }
  if (!(std::isfinite(tolerance_m) && tolerance_m >= 0)) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("snap tolerance {:g} m must be finite and >= 0", tolerance_m)};
  }
  const GridGeometry& g = graph.grid();
  const double r = g.resolution_m;
  const double slack = 0.5 * r;
  // Under open sky (or a high roof) a level's air space ends this far above its ground: a z
  // far above every ground does not point at the top one.
  constexpr double kMaxAirSpaceM = 2.5;
  // Distance from p to a node's level: horizontal to its reference point, plus how far p's z
  // lies outside the free space of that level (from its ground up to its ceiling). So a z
  // anywhere in a level's air space selects that level, as a z "pointing at" it should.
  const auto level_distance = [&](int node) {
    const Eigen::Vector3d pos = graph.position(node);
    const double ground = graph.ground_z(node);
    const double ceiling = ground + std::min<double>(graph.ceiling_clearance(node), kMaxAirSpaceM);
    const double below = std::max(0.0, ground - slack - p.z());
    const double above = std::max(0.0, p.z() - ceiling);
    return std::hypot((pos - p).head<2>().norm(), below + above);
  };
  const auto make = [&](int node) {
    return SnapResult{node, graph.position(node), graph.level(node), level_distance(node)};
  };

  // 1. p's own column, at the level its z points at.
  const Eigen::Vector3i c = g.CellOf(p);
  {
    int chosen = -1;
    for (const std::int32_t m : graph.ColumnNodes(c.x(), c.y())) {
      if (graph.ground_z(m) <= p.z() + slack) chosen = m;  // Lowest first: keep the highest.
    }
    if (chosen >= 0 && level_distance(chosen) <= tolerance_m && (!accept || accept(chosen))) {
      return make(chosen);
    }
  }

  // 2. Columns within tolerance, ring by ring. Score = level distance, plus a penalty larger
  // than any in-tolerance distance for ground above p, so ground below always wins.
  const double above_penalty = 2.0 * tolerance_m + r;
  const int max_ring = static_cast<int>(std::ceil(tolerance_m / r)) + 1;
  int best = -1;
  bool turned_down = false;  // A node within tolerance that `accept` refused.
  double best_score = std::numeric_limits<double>::infinity();
  // Columns of a ring lie at least (ring - 1) · r horizontally from p.
  VisitRings(
      graph, c, max_ring, [&](int ring) { return best >= 0 && best_score <= (ring - 1) * r; },
      [&](int m) {
        const double d = level_distance(m);
        if (d > tolerance_m) return;
        if (accept && !accept(m)) {
          turned_down = true;
          return;
        }
        const double score = d + (graph.ground_z(m) > p.z() + slack ? above_penalty : 0.0);
        if (score < best_score) {
          best_score = score;
          best = m;
        }
      });
  if (best >= 0) return make(best);
  if (turned_down) {
    return Error{off_ground_code,
                 fmt::format("{} {} m: all traversable ground within {:.2f} m puts the robot's "
                             "reference point {}; move it into open space",
                             what, internal::FormatPoint(p), tolerance_m, refusal)};
  }

  // 3. Nothing within tolerance: name the nearest node anywhere, ring by ring out to the
  // grid's far corner. Callers that try many points come here often (a fleet plan looking for
  // a stop beside its route tries points in walls): a scan of every node for each made one
  // fleet plan on the garage take 30 s.
  int nearest = -1;
  double nearest_d = std::numeric_limits<double>::infinity();
  const int far_ring = std::max({c.x(), g.size.x() - 1 - c.x(), c.y(), g.size.y() - 1 - c.y()});
  VisitRings(
      graph, c, far_ring, [&](int ring) { return nearest >= 0 && nearest_d <= (ring - 1) * r; },
      [&](int m) {
        const double d = level_distance(m);
        if (d < nearest_d) {
          nearest_d = d;
          nearest = m;
        }
      });
  std::string message = fmt::format("{} {} m has no traversable ground within {:.2f} m", what,
                                    internal::FormatPoint(p), tolerance_m);
  std::map<std::string, std::string> details;
  if (nearest >= 0) {
    const Eigen::Vector3d at = graph.position(nearest);
    message +=
        fmt::format("; the nearest is {} m ({:.2f} m away)", internal::FormatPoint(at), nearest_d);
    details = {{"nearest_x_m", DetailNumber(at.x())},
               {"nearest_y_m", DetailNumber(at.y())},
               {"nearest_z_m", DetailNumber(at.z())},
               {"nearest_level", std::to_string(graph.level(nearest))},
               {"nearest_distance_m", DetailNumber(nearest_d)}};
  } else {
    message += "; the map has no traversable ground for these traversability parameters";
  }
  return Error{off_ground_code, message, {}, std::move(details)};
}

}  // namespace strata
