#include "strata/travel_costs.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planner.hpp"
#include "strata/point_cloud.hpp"

namespace strata {
namespace internal {

// The graph the searches of one query run on: the SurfaceGraph's nodes of the components that
// matter, merged per block of columns and level (see TravelCostConfig::coarse_cell_m), as a
// compressed adjacency list with the edge costs computed once.
struct CoarseGraph {
  struct Edge {
    std::int32_t to;
    float cost;  // EdgeCost between the two representatives [m].
  };
  std::vector<std::int32_t> representative;  // SurfaceGraph node standing for each node.
  std::vector<Eigen::Vector3f> position;     // Its reference point [m].
  std::vector<std::uint32_t> edge_begin{0};  // Nodes + 1 offsets into edges.
  std::vector<Edge> edges;
  // Buckets of the search's queue: no wider than the cheapest edge, so a node settled from a
  // bucket can never improve another node of the same bucket, and Dijkstra stays exact.
  float bucket_width = 1.0f;
  // A power of two (a push finds its bucket by a mask), enough that a push never wraps onto
  // the bucket being settled.
  int bucket_count = 2;
  int surface_nodes = 0;

  int node_count() const { return static_cast<int>(representative.size()); }
};

// The buffers of EstimateTravelTime, kept between calls: a matrix estimates thousands of
// paths, and allocating them each time cost as much as the estimate itself.
struct TravelTimeScratch {
  std::vector<Eigen::Vector3d> points, smoothed, integral;
  std::vector<double> arc, length, cap, accel, slope, speed;
  std::vector<Eigen::Vector2d> heading;
};

// One thread's search state, reset between searches by the list of nodes it touched.
struct TravelSearchState {
  std::vector<float> dist;
  std::vector<std::int32_t> parent;
  std::vector<std::uint8_t> settled;
  std::vector<std::int32_t> targets_at;  // Targets standing on each node.
  std::vector<std::int32_t> touched;
  std::vector<std::vector<std::int32_t>> buckets;
  std::vector<std::int32_t> path_nodes;
  std::vector<Eigen::Vector3d> path;
  TravelTimeScratch time_scratch;

  void Fit(int nodes, int bucket_count) {
    if (dist.size() != static_cast<std::size_t>(nodes)) {
      dist.assign(static_cast<std::size_t>(nodes), std::numeric_limits<float>::infinity());
      parent.assign(static_cast<std::size_t>(nodes), -1);
      settled.assign(static_cast<std::size_t>(nodes), 0);
      targets_at.assign(static_cast<std::size_t>(nodes), 0);
      touched.clear();
    }
    if (buckets.size() < static_cast<std::size_t>(bucket_count)) {
      buckets.resize(static_cast<std::size_t>(bucket_count));
    }
  }
  // Call before a node's first change (a distance, or a target on it); a node listed twice
  // is only reset twice.
  void Touch(int node) {
    if (dist[node] == std::numeric_limits<float>::infinity()) touched.push_back(node);
  }
  void Clear() {
    for (const std::int32_t n : touched) {
      dist[n] = std::numeric_limits<float>::infinity();
      parent[n] = -1;
      settled[n] = 0;
      targets_at[n] = 0;
    }
    touched.clear();
    for (auto& bucket : buckets) bucket.clear();
  }
};

}  // namespace internal

namespace {

constexpr int kNodesPerPoll = 4096;
// Relative difference under which two path costs count as equal: the search then keeps the
// predecessor that lies straighter towards its source (see RunSearch).
constexpr float kTieTolerance = 1e-6f;

Error Cancelled() { return Error{ErrorCode::kCancelled, "estimating travel costs was cancelled"}; }

// kInvalidInput for a position that is not finite or lies beyond kMaxAbsCoordinateM.
Status CheckPosition(const Eigen::Vector3d& p, const std::string& path) {
  for (int i = 0; i < 3; ++i) {
    if (std::abs(p(i)) <= kMaxAbsCoordinateM) continue;  // False for NaN too.
    const std::string field = internal::FieldPath(path, std::string(1, "xyz"[i]));
    return Error{ErrorCode::kInvalidInput,
                 std::isfinite(p(i))
                     ? fmt::format("{} = {:g} m is beyond ±{:g} m", field, p(i), kMaxAbsCoordinateM)
                     : fmt::format("{} must be finite, got {:g}", field, p(i)),
                 field};
  }
  return Status::Ok();
}

// The exact time-optimal time over one stretch of length `length` entered at v0 and left at
// v1, at most `cap` fast, accelerating and braking at `accel` (> 0); v0, v1 <= cap and
// |v0² − v1²| <= 2·accel·length (the passes guarantee both).
double StretchTime(double v0, double v1, double cap, double accel, double length) {
  const double peak_squared = 0.5 * (v0 * v0 + v1 * v1) + accel * length;
  const double peak = std::min(cap, std::sqrt(peak_squared));
  if (peak <= 0) return 0;
  const double speeding_up = (peak * peak - v0 * v0) / (2 * accel);
  const double slowing_down = (peak * peak - v1 * v1) / (2 * accel);
  const double cruise = std::max(0.0, length - speeding_up - slowing_down);
  return (peak - v0) / accel + (peak - v1) / accel + cruise / peak;
}

// Resamples the polyline `points` (repeated points allowed) every ~`spacing` of arc length
// and averages it over ±window around each sample (less near the ends, which stay fixed),
// into *smoothed.
void SmoothPolyline(std::span<const Eigen::Vector3d> points, double window, double spacing,
                    internal::TravelTimeScratch* scratch, std::vector<Eigen::Vector3d>* smoothed) {
  const std::size_t n = points.size();
  std::vector<double>& arc = scratch->arc;
  // integral[i] = ∫ p(s) ds from 0 to arc[i], so a window's mean is a difference of integrals.
  std::vector<Eigen::Vector3d>& integral = scratch->integral;
  arc.assign(n, 0.0);
  integral.assign(n, Eigen::Vector3d::Zero());
  for (std::size_t i = 1; i < n; ++i) {
    const double length = (points[i] - points[i - 1]).norm();
    arc[i] = arc[i - 1] + length;
    integral[i] = integral[i - 1] + 0.5 * length * (points[i] + points[i - 1]);
  }
  const double total = arc.back();
  // The segment holding arc length s, from *cursor on (each cursor only moves forward).
  const auto locate = [&](double s, std::size_t* cursor) {
    while (*cursor + 2 < n && arc[*cursor + 1] < s) ++*cursor;
    return *cursor;
  };
  const auto point_at = [&](double s, std::size_t i) -> Eigen::Vector3d {
    const double length = arc[i + 1] - arc[i];
    const double t = length > 0 ? std::clamp((s - arc[i]) / length, 0.0, 1.0) : 0.0;
    return points[i] + t * (points[i + 1] - points[i]);
  };
  const auto integral_at = [&](double s, std::size_t* cursor) -> Eigen::Vector3d {
    const std::size_t i = locate(s, cursor);
    return integral[i] + 0.5 * (s - arc[i]) * (points[i] + point_at(s, i));
  };

  const int samples = std::max(2, static_cast<int>(std::ceil(total / spacing)) + 1);
  smoothed->clear();
  std::size_t at_cursor = 0, low_cursor = 0, high_cursor = 0;
  for (int k = 0; k < samples; ++k) {
    const double s = total * k / (samples - 1);
    const double half = std::min({window, s, total - s});
    if (k == 0 || k == samples - 1) {
      smoothed->push_back(k == 0 ? points.front() : points.back());
    } else if (half <= 1e-9) {
      smoothed->push_back(point_at(s, locate(s, &at_cursor)));
    } else {
      const Eigen::Vector3d low = integral_at(s - half, &low_cursor);
      const Eigen::Vector3d high = integral_at(s + half, &high_cursor);
      smoothed->push_back((high - low) / (2 * half));
    }
  }
}

TravelTimeEstimate EstimateTravelTime(std::span<const Eigen::Vector3d> path_m,
                                      const RobotProfile& profile, const TravelCostConfig& config,
                                      internal::TravelTimeScratch* scratch) {
  constexpr double kSamePointM = 1e-9;
  std::vector<Eigen::Vector3d>& points = scratch->points;
  points.clear();
  if (path_m.size() >= 2 && config.smoothing_m > 0) {
    // Samples smoothing_m apart, half the window's width: the averaged path holds no detail
    // shorter than the window, and a sample costs about 0.05 µs.
    constexpr double kFinestSpacingM = 0.05;
    SmoothPolyline(path_m, config.smoothing_m, std::max(config.smoothing_m, kFinestSpacingM),
                   scratch, &scratch->smoothed);
    path_m = scratch->smoothed;
  }
  for (const Eigen::Vector3d& p : path_m) {
    if (points.empty() || (p - points.back()).norm() > kSamePointM) points.push_back(p);
  }
  if (points.size() < 2) return {};

  const double margin = config.limit_margin;
  const double speed_h = config.speed_fraction * profile.max_speed_horizontal_mps;
  const double speed_v = config.speed_fraction * profile.max_speed_vertical_mps;
  const double accel_h = margin * profile.max_accel_horizontal_mps2;
  const double accel_v = margin * profile.max_accel_vertical_mps2;
  constexpr double kInfinity = std::numeric_limits<double>::infinity();

  // Per stretch: its length, the horizontal unit direction (zero when vertical), and its caps.
  // A stretch moving horizontal_share of its length horizontally and vertical_share vertically
  // may go at most min(bound_h / horizontal_share, bound_v / vertical_share) along itself, for
  // speed and acceleration alike.
  const std::size_t stretches = points.size() - 1;
  std::vector<double>& length = scratch->length;
  std::vector<double>& cap = scratch->cap;
  std::vector<double>& accel = scratch->accel;
  std::vector<double>& slope = scratch->slope;
  std::vector<Eigen::Vector2d>& heading = scratch->heading;
  length.resize(stretches);
  cap.resize(stretches);
  accel.resize(stretches);
  slope.resize(stretches);
  heading.resize(stretches);
  TravelTimeEstimate estimate;
  for (std::size_t k = 0; k < stretches; ++k) {
    const Eigen::Vector3d delta = points[k + 1] - points[k];
    length[k] = delta.norm();
    const double horizontal = delta.head<2>().norm();
    const double vertical = std::abs(delta.z());
    const double per_horizontal = horizontal > 0 ? length[k] / horizontal : kInfinity;
    const double per_vertical = vertical > 0 ? length[k] / vertical : kInfinity;
    cap[k] = std::min(speed_h * per_horizontal, speed_v * per_vertical);
    accel[k] = std::min(accel_h * per_horizontal, accel_v * per_vertical);
    slope[k] = delta.z() / length[k];
    heading[k] = horizontal > kSamePointM ? Eigen::Vector2d(delta.head<2>() / horizontal)
                                          : Eigen::Vector2d::Zero();
    estimate.length_m += length[k];
  }
  // Speed at each point, squared (the passes then need no square root): 0 at both ends;
  // inside, at most both stretches' caps and what the bend allows: lateral acceleration v²κ
  // within the horizontal bound (κ from the change of horizontal direction, |Δu| ≈ the turn
  // angle, over the stretches' mean length), and the change of slope's v²·d²z/ds² within the
  // vertical one.
  std::vector<double>& speed_squared = scratch->speed;
  speed_squared.assign(points.size(), 0.0);
  for (std::size_t k = 1; k < stretches; ++k) {
    const double cap_here = std::min(cap[k - 1], cap[k]);
    double bound = cap_here * cap_here;
    const double mean_length = 0.5 * (length[k - 1] + length[k]);
    if (heading[k - 1].x() != 0 || heading[k - 1].y() != 0) {
      if (heading[k].x() != 0 || heading[k].y() != 0) {
        const double curvature = (heading[k] - heading[k - 1]).norm() / mean_length;
        if (curvature > 0) bound = std::min(bound, accel_h / curvature);
      }
    }
    const double slope_change = std::abs(slope[k] - slope[k - 1]) / mean_length;
    if (slope_change > 0) bound = std::min(bound, accel_v / slope_change);
    speed_squared[k] = bound;
  }
  for (std::size_t k = 0; k < stretches; ++k) {  // Speeding up.
    speed_squared[k + 1] =
        std::min(speed_squared[k + 1], speed_squared[k] + 2 * accel[k] * length[k]);
  }
  for (std::size_t k = stretches; k-- > 0;) {  // Slowing down.
    speed_squared[k] = std::min(speed_squared[k], speed_squared[k + 1] + 2 * accel[k] * length[k]);
  }
  for (std::size_t k = 0; k < stretches; ++k) {
    estimate.time_s += StretchTime(std::sqrt(speed_squared[k]), std::sqrt(speed_squared[k + 1]),
                                   cap[k], accel[k], length[k]);
  }
  return estimate;
}

}  // namespace

Status TravelCostConfig::Validate(std::string_view path) const {
  using internal::FieldPath;
  if (Status s = search.Validate(FieldPath(path, "search")); !s) return s;
  if (!(std::isfinite(coarse_cell_m) && coarse_cell_m >= 0)) {
    return internal::OutOfRange(FieldPath(path, "coarse_cell_m"), coarse_cell_m, ">= 0 and finite");
  }
  if (!(std::isfinite(smoothing_m) && smoothing_m >= 0)) {
    return internal::OutOfRange(FieldPath(path, "smoothing_m"), smoothing_m, ">= 0 and finite");
  }
  if (!(limit_margin > 0 && limit_margin <= 1)) {
    return internal::OutOfRange(FieldPath(path, "limit_margin"), limit_margin, "in (0, 1]");
  }
  if (!(speed_fraction > 0 && speed_fraction <= 1)) {
    return internal::OutOfRange(FieldPath(path, "speed_fraction"), speed_fraction, "in (0, 1]");
  }
  if (!(std::isfinite(min_obstacle_distance_m) && min_obstacle_distance_m >= 0)) {
    return internal::OutOfRange(FieldPath(path, "min_obstacle_distance_m"), min_obstacle_distance_m,
                                ">= 0 and finite");
  }
  if (max_nodes < 1) return internal::OutOfRange(FieldPath(path, "max_nodes"), max_nodes, ">= 1");
  return Status::Ok();
}

TravelTimeEstimate EstimateTravelTime(std::span<const Eigen::Vector3d> path_m,
                                      const RobotProfile& profile, const TravelCostConfig& config) {
  internal::TravelTimeScratch scratch;
  return EstimateTravelTime(path_m, profile, config, &scratch);
}

TravelCostWorkspace::TravelCostWorkspace()
    : state_(std::make_unique<internal::TravelSearchState>()) {}
TravelCostWorkspace::~TravelCostWorkspace() = default;
TravelCostWorkspace::TravelCostWorkspace(TravelCostWorkspace&&) noexcept = default;
TravelCostWorkspace& TravelCostWorkspace::operator=(TravelCostWorkspace&&) noexcept = default;

TravelCostQuery::~TravelCostQuery() = default;
TravelCostQuery::TravelCostQuery(TravelCostQuery&&) noexcept = default;
TravelCostQuery& TravelCostQuery::operator=(TravelCostQuery&&) noexcept = default;

int TravelCostQuery::search_node_count() const { return coarse_->node_count(); }
int TravelCostQuery::surface_node_count() const { return coarse_->surface_nodes; }

namespace {

// Builds the coarse graph over the nodes `included` accepts; *coarse_of receives each
// SurfaceGraph node's search node (-1 when not included).
Expected<std::shared_ptr<internal::CoarseGraph>> BuildCoarseGraph(
    const SurfaceGraph& graph, int block, const SearchConfig& search,
    const std::function<bool(int)>& included, const std::function<bool()>& should_stop,
    std::vector<std::int32_t>* coarse_of) {
  auto coarse = std::make_shared<internal::CoarseGraph>();
  coarse_of->assign(static_cast<std::size_t>(graph.node_count()), -1);
  const GridGeometry& grid = graph.grid();
  const int blocks_x = (grid.size.x() + block - 1) / block;
  const int blocks_y = (grid.size.y() + block - 1) / block;
  std::vector<std::int32_t> members;  // Of the block at hand, ascending.
  std::vector<int> root;              // Union-find over members.
  std::vector<std::int32_t> group_members;
  std::vector<std::uint32_t> group_begin{0};  // Search node -> its members in group_members.
  // Every member's neighbours, found once: the groups need them, then the edges.
  std::vector<std::int32_t> block_neighbours;        // Of the block's members, in turn.
  std::vector<std::uint32_t> block_neighbour_begin;  // Members + 1 offsets into it.
  std::vector<std::int32_t> neighbours;              // Of group_members, in turn.
  std::vector<std::uint32_t> neighbour_begin{0};     // group_members + 1 offsets into it.
  const auto find = [&root](int i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };

  for (int by = 0; by < blocks_y; ++by) {
    if (should_stop && should_stop()) return Cancelled();
    for (int bx = 0; bx < blocks_x; ++bx) {
      members.clear();
      for (int iy = by * block; iy < std::min((by + 1) * block, grid.size.y()); ++iy) {
        for (int ix = bx * block; ix < std::min((bx + 1) * block, grid.size.x()); ++ix) {
          for (const std::int32_t m : graph.ColumnNodes(ix, iy)) {
            if (included(m)) members.push_back(m);
          }
        }
      }
      if (members.empty()) continue;
      std::sort(members.begin(), members.end());
      root.resize(members.size());
      std::iota(root.begin(), root.end(), 0);
      block_neighbours.clear();
      block_neighbour_begin.assign(1, 0);
      for (std::size_t i = 0; i < members.size(); ++i) {
        graph.ForEachNeighbor(members[i], [&](int m) {
          block_neighbours.push_back(m);
          const auto it = std::lower_bound(members.begin(), members.end(), m);
          if (it == members.end() || *it != m) return;  // Outside the block, or left out.
          root[find(static_cast<int>(i))] = find(static_cast<int>(it - members.begin()));
        });
        block_neighbour_begin.push_back(static_cast<std::uint32_t>(block_neighbours.size()));
      }
      // One search node per group, at the member nearest the group's mean point; of members
      // equally near (the four of a full block), the first, so that the representatives of
      // open ground form a regular lattice and its straight lines cost exactly alike.
      for (std::size_t i = 0; i < members.size(); ++i) {
        if (find(static_cast<int>(i)) != static_cast<int>(i)) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        int count = 0;
        for (std::size_t j = 0; j < members.size(); ++j) {
          if (find(static_cast<int>(j)) != static_cast<int>(i)) continue;
          mean += graph.position(members[j]);
          ++count;
        }
        mean /= count;
        const auto id = static_cast<std::int32_t>(coarse->representative.size());
        std::int32_t best = -1;
        double best_distance = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < members.size(); ++j) {
          if (find(static_cast<int>(j)) != static_cast<int>(i)) continue;
          const double distance = (graph.position(members[j]) - mean).squaredNorm();
          if (distance < best_distance - 1e-9) {
            best_distance = distance;
            best = members[j];
          }
          (*coarse_of)[static_cast<std::size_t>(members[j])] = id;
          group_members.push_back(members[j]);
          neighbours.insert(neighbours.end(), block_neighbours.begin() + block_neighbour_begin[j],
                            block_neighbours.begin() + block_neighbour_begin[j + 1]);
          neighbour_begin.push_back(static_cast<std::uint32_t>(neighbours.size()));
        }
        coarse->representative.push_back(best);
        coarse->position.emplace_back(graph.position(best).cast<float>());
        group_begin.push_back(static_cast<std::uint32_t>(group_members.size()));
      }
    }
  }
  coarse->surface_nodes = static_cast<int>(group_members.size());

  // Edges: search nodes are adjacent when any of their members are.
  float cheapest = std::numeric_limits<float>::infinity();
  float dearest = 0;
  std::vector<std::int32_t> adjacent;
  const int nodes = coarse->node_count();
  coarse->edge_begin.reserve(static_cast<std::size_t>(nodes) + 1);
  for (int a = 0; a < nodes; ++a) {
    if (a % kNodesPerPoll == 0 && should_stop && should_stop()) return Cancelled();
    adjacent.clear();
    for (std::uint32_t k = neighbour_begin[group_begin[a]]; k < neighbour_begin[group_begin[a + 1]];
         ++k) {
      const std::int32_t b = (*coarse_of)[static_cast<std::size_t>(neighbours[k])];
      if (b >= 0 && b != a) adjacent.push_back(b);
    }
    std::sort(adjacent.begin(), adjacent.end());
    adjacent.erase(std::unique(adjacent.begin(), adjacent.end()), adjacent.end());
    for (const std::int32_t b : adjacent) {
      const auto cost = static_cast<float>(
          EdgeCost(graph, coarse->representative[a], coarse->representative[b], search));
      cheapest = std::min(cheapest, cost);
      dearest = std::max(dearest, cost);
      coarse->edges.push_back({b, cost});
    }
    coarse->edge_begin.push_back(static_cast<std::uint32_t>(coarse->edges.size()));
  }
  if (!coarse->edges.empty()) {
    // Representatives of different blocks lie at least a cell apart, so cheapest > 0.
    coarse->bucket_width = cheapest;
    coarse->bucket_count =
        static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::ceil(dearest / cheapest)) + 2));
  }
  return coarse;
}

}  // namespace

Expected<TravelCostQuery> TravelCostQuery::Prepare(
    const SurfaceGraph& graph, const RobotProfile& profile,
    std::span<const Eigen::Vector3d> starts_m, std::span<const Eigen::Vector3d> goals_m,
    std::span<const KeepOutZone> zones, double snap_tolerance_m, const TravelCostConfig& config,
    const std::function<bool()>& should_stop) {
  if (Status s = config.Validate(); !s) return std::move(s).error();
  if (starts_m.empty() || goals_m.empty()) {
    const char* field = starts_m.empty() ? "starts_m" : "goals_m";
    return Error{ErrorCode::kInvalidInput,
                 std::string(field) + " is empty: give at least one start and one goal", field};
  }
  for (std::size_t i = 0; i < starts_m.size(); ++i) {
    if (Status s = CheckPosition(starts_m[i], "starts_m[" + std::to_string(i) + "]"); !s)
      return s.error();
  }
  for (std::size_t j = 0; j < goals_m.size(); ++j) {
    if (Status s = CheckPosition(goals_m[j], "goals_m[" + std::to_string(j) + "]"); !s)
      return s.error();
  }
  if (!(std::isfinite(snap_tolerance_m) && snap_tolerance_m >= 0)) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("snap tolerance {:g} m must be finite and >= 0", snap_tolerance_m)};
  }

  TravelCostQuery query;
  query.graph_ = &graph;
  query.profile_ = profile;
  query.config_ = config;
  // Ends as Plan takes them: snapped, then refused inside a keep-out zone.
  const auto snap = [&](const Eigen::Vector3d& p, ErrorCode off_ground, ErrorCode in_zone,
                        const char* what) -> Expected<SnapResult> {
    Expected<SnapResult> snapped =
        SnapEndpoint(graph, p, snap_tolerance_m, off_ground, config.min_obstacle_distance_m);
    if (!snapped) return snapped;
    if (const int zone = FirstViolatedKeepOut(zones, profile, snapped->position_m); zone >= 0) {
      return Error{in_zone, std::string(what) + " " + internal::FormatPoint(snapped->position_m) +
                                " m puts the robot inside " + zones[zone].name +
                                ": move it out of the zone"};
    }
    return snapped;
  };
  for (const Eigen::Vector3d& p : starts_m) {
    if (should_stop && should_stop()) return Cancelled();
    query.starts_.push_back(
        snap(p, ErrorCode::kStartOffGround, ErrorCode::kStartInKeepOut, "start"));
  }
  for (const Eigen::Vector3d& p : goals_m) {
    if (should_stop && should_stop()) return Cancelled();
    query.goals_.push_back(snap(p, ErrorCode::kGoalOffGround, ErrorCode::kGoalInKeepOut, "goal"));
  }

  // The components holding a valid start and a valid goal are the only ones searched.
  std::vector<std::uint8_t> has_start(static_cast<std::size_t>(graph.component_count()), 0);
  std::vector<std::uint8_t> searched(has_start.size(), 0);
  std::vector<std::int32_t> ends;  // Snapped nodes of valid ends: never left out.
  for (const Expected<SnapResult>& s : query.starts_) {
    if (!s) continue;
    has_start[static_cast<std::size_t>(graph.component(s->node))] = 1;
    ends.push_back(s->node);
  }
  for (const Expected<SnapResult>& g : query.goals_) {
    if (!g) continue;
    const auto c = static_cast<std::size_t>(graph.component(g->node));
    searched[c] = has_start[c];
    ends.push_back(g->node);
  }
  std::sort(ends.begin(), ends.end());
  std::int64_t nodes = 0;
  for (int n = 0; n < graph.node_count(); ++n) {
    nodes += searched[static_cast<std::size_t>(graph.component(n))];
  }
  if (nodes > config.max_nodes) {
    return Error{ErrorCode::kResourceExhausted,
                 fmt::format("the ground connecting these starts and goals holds {} graph nodes, "
                             "more than the {} one estimate may search (costs.max_nodes): ask "
                             "for ends on a smaller part of the map, or plan the pairs one by one",
                             nodes, config.max_nodes),
                 "costs.max_nodes"};
  }
  const auto included = [&](int n) {
    if (!searched[static_cast<std::size_t>(graph.component(n))]) return false;
    if (zones.empty() || std::binary_search(ends.begin(), ends.end(), n)) return true;
    return FirstViolatedKeepOut(zones, profile, graph.position(n)) < 0;
  };
  const int block = std::clamp(
      static_cast<int>(std::lround(config.coarse_cell_m / graph.grid().resolution_m)), 1, 8);
  std::vector<std::int32_t> coarse_of;
  Expected<std::shared_ptr<internal::CoarseGraph>> coarse =
      BuildCoarseGraph(graph, block, config.search, included, should_stop, &coarse_of);
  if (!coarse) return std::move(coarse).error();
  query.coarse_ = std::move(coarse).value();

  // Search nodes of the ends, and the searches: from the smaller side.
  const auto node_of = [&](const Expected<SnapResult>& end) {
    return end && searched[static_cast<std::size_t>(graph.component(end->node))]
               ? coarse_of[static_cast<std::size_t>(end->node)]
               : -1;
  };
  for (const auto& s : query.starts_) query.start_nodes_.push_back(node_of(s));
  for (const auto& g : query.goals_) query.goal_nodes_.push_back(node_of(g));
  const auto searchable = [](const std::vector<int>& nodes_of_ends) {
    std::vector<int> indices;
    for (std::size_t i = 0; i < nodes_of_ends.size(); ++i) {
      if (nodes_of_ends[i] >= 0) indices.push_back(static_cast<int>(i));
    }
    return indices;
  };
  std::vector<int> from_starts = searchable(query.start_nodes_);
  std::vector<int> from_goals = searchable(query.goal_nodes_);
  query.search_from_starts_ = from_starts.size() <= from_goals.size();
  query.sources_ = query.search_from_starts_ ? std::move(from_starts) : std::move(from_goals);
  return query;
}

TravelCostMatrix TravelCostQuery::InitialMatrix() const {
  TravelCostMatrix matrix;
  matrix.start_count = static_cast<int>(starts_.size());
  matrix.goal_count = static_cast<int>(goals_.size());
  matrix.cells.resize(starts_.size() * goals_.size());
  for (int i = 0; i < matrix.start_count; ++i) {
    for (int j = 0; j < matrix.goal_count; ++j) {
      TravelCost& cell = matrix.at(i, j);
      const Expected<SnapResult>& start = starts_[static_cast<std::size_t>(i)];
      const Expected<SnapResult>& goal = goals_[static_cast<std::size_t>(j)];
      if (!start) {
        cell.failure = start.error().code;
      } else if (!goal) {
        cell.failure = goal.error().code;
      } else if (graph_->component(start->node) != graph_->component(goal->node)) {
        cell.failure = ErrorCode::kGoalUnreachable;
      }
    }
  }
  return matrix;
}

Status TravelCostQuery::RunSearch(int k, TravelCostWorkspace* workspace, TravelCostMatrix* matrix,
                                  const std::function<bool()>& should_stop,
                                  TravelSearchStats* stats) const {
  const internal::CoarseGraph& graph = *coarse_;
  internal::TravelSearchState& state = *workspace->state_;
  state.Fit(graph.node_count(), graph.bucket_count);
  const int index = sources_[static_cast<std::size_t>(k)];
  const std::vector<int>& target_nodes = search_from_starts_ ? goal_nodes_ : start_nodes_;
  const int source =
      (search_from_starts_ ? start_nodes_ : goal_nodes_)[static_cast<std::size_t>(index)];
  const auto cell = [&](int target) -> TravelCost& {
    return search_from_starts_ ? matrix->at(index, target) : matrix->at(target, index);
  };
  const int source_component =
      graph_->component(graph.representative[static_cast<std::size_t>(source)]);
  const auto is_target = [&](int target) {
    const int node = target_nodes[static_cast<std::size_t>(target)];
    return node >= 0 && graph_->component(graph.representative[static_cast<std::size_t>(node)]) ==
                            source_component;
  };

  int remaining = 0;  // Target nodes not yet settled.
  for (int t = 0; t < static_cast<int>(target_nodes.size()); ++t) {
    if (!is_target(t)) continue;
    const int node = target_nodes[static_cast<std::size_t>(t)];
    state.Touch(node);
    if (state.targets_at[node]++ == 0) ++remaining;
  }

  // Dijkstra with a bucket queue (see CoarseGraph::bucket_width). Among predecessors that
  // reach a node at equal cost, it keeps the one whose step points most nearly back at the
  // source: the grid has many equally cheap zigzags between two points, and this picks the
  // one closest to the straight line, as the trajectory (and A*'s heuristic) would.
  const Eigen::Vector3f origin = graph.position[static_cast<std::size_t>(source)];
  const auto straighter = [&](int candidate, int current, int node) {
    const Eigen::Vector3f at = graph.position[static_cast<std::size_t>(node)];
    const Eigen::Vector3f back = origin - at;
    const Eigen::Vector3f a = graph.position[static_cast<std::size_t>(candidate)] - at;
    const Eigen::Vector3f b = graph.position[static_cast<std::size_t>(current)] - at;
    // cos∠(back, a) > cos∠(back, b), compared without square roots.
    const float along_a = back.dot(a), along_b = back.dot(b);
    const float cos_a = along_a * std::abs(along_a) * b.squaredNorm();
    const float cos_b = along_b * std::abs(along_b) * a.squaredNorm();
    return cos_a > cos_b;
  };
  const float inverse_width = 1.0f / graph.bucket_width;
  const auto bucket_mask = static_cast<std::int64_t>(graph.bucket_count - 1);
  // Raw views for the inner loop: pushes into the buckets would otherwise make the compiler
  // reload every array's address.
  float* const dist = state.dist.data();
  std::int32_t* const parent = state.parent.data();
  std::uint8_t* const settled = state.settled.data();
  const std::int32_t* const targets_at = state.targets_at.data();
  const internal::CoarseGraph::Edge* const edges = graph.edges.data();
  const std::uint32_t* const edge_begin = graph.edge_begin.data();
  state.Touch(source);
  dist[source] = 0;
  state.buckets[0].push_back(source);
  std::int64_t pending = 1;
  int expansions = 0;
  bool budget_spent = false;
  for (std::int64_t current = 0; pending > 0 && remaining > 0 && !budget_spent; ++current) {
    std::vector<std::int32_t>& bucket =
        state.buckets[static_cast<std::size_t>(current & bucket_mask)];
    for (std::size_t q = 0; q < bucket.size() && remaining > 0; ++q) {
      const std::int32_t n = bucket[q];
      --pending;
      if (settled[n]) continue;  // Settled from an earlier, cheaper entry.
      if (expansions >= config_.search.max_expansions) {
        budget_spent = true;
        break;
      }
      if (expansions % 1024 == 0 && should_stop && should_stop()) {
        state.Clear();
        return Cancelled();
      }
      settled[n] = 1;
      ++expansions;
      if (targets_at[n] > 0) --remaining;
      const float d = dist[n];
      for (std::uint32_t e = edge_begin[n]; e < edge_begin[n + 1]; ++e) {
        const std::int32_t m = edges[e].to;
        if (settled[m]) continue;
        const float candidate = d + edges[e].cost;
        const float known = dist[m];
        if (candidate < known * (1 - kTieTolerance)) {
          if (known == std::numeric_limits<float>::infinity()) state.touched.push_back(m);
          dist[m] = candidate;
          parent[m] = n;
          // Never into the bucket being settled, even where rounding would put it there.
          const std::int64_t b =
              std::max(current + 1, static_cast<std::int64_t>(candidate * inverse_width));
          state.buckets[static_cast<std::size_t>(b & bucket_mask)].push_back(m);
          ++pending;
        } else if (candidate <= known * (1 + kTieTolerance) && straighter(n, parent[m], m)) {
          parent[m] = n;
        }
      }
    }
    bucket.clear();
  }
  if (stats != nullptr) stats->expansions = expansions;

  // The cells: each target's path, start to goal, and the drive along it.
  for (int t = 0; t < static_cast<int>(target_nodes.size()); ++t) {
    if (!is_target(t)) continue;
    if (t % 64 == 0 && should_stop && should_stop()) {
      state.Clear();
      return Cancelled();
    }
    TravelCost& out = cell(t);
    const int node = target_nodes[static_cast<std::size_t>(t)];
    if (!state.settled[node]) {
      // The components connect them, so only keep-out zones (or the budget) stood between.
      out = TravelCost{};
      out.failure = budget_spent ? ErrorCode::kSearchBudgetExhausted : ErrorCode::kGoalUnreachable;
      continue;
    }
    state.path_nodes.clear();
    for (int v = node; v >= 0; v = v == source ? -1 : state.parent[v])
      state.path_nodes.push_back(v);
    if (search_from_starts_) std::reverse(state.path_nodes.begin(), state.path_nodes.end());
    const SnapResult& start = *starts_[static_cast<std::size_t>(search_from_starts_ ? index : t)];
    const SnapResult& goal = *goals_[static_cast<std::size_t>(search_from_starts_ ? t : index)];
    out = TravelCost{};
    out.search_cost = state.dist[node];
    // The drive runs from the start through the search nodes between the ends' own (whose
    // representatives may lie up to a block behind an end) to the goal.
    state.path.clear();
    state.path.push_back(start.position_m);
    for (std::size_t i = 0; i < state.path_nodes.size(); ++i) {
      const Eigen::Vector3d p =
          graph.position[static_cast<std::size_t>(state.path_nodes[i])].cast<double>();
      if (i > 0) {
        out.search_length_m +=
            (p - graph.position[static_cast<std::size_t>(state.path_nodes[i - 1])].cast<double>())
                .norm();
      }
      if (i > 0 && i + 1 < state.path_nodes.size()) state.path.push_back(p);
    }
    state.path.push_back(goal.position_m);
    const TravelTimeEstimate drive =
        EstimateTravelTime(state.path, profile_, config_, &state.time_scratch);
    out.time_s = drive.time_s;
    out.length_m = drive.length_m;
  }
  state.Clear();
  return Status::Ok();
}

Expected<TravelCostMatrix> EstimateTravelCosts(
    const SurfaceGraph& graph, const RobotProfile& profile,
    std::span<const Eigen::Vector3d> starts_m, std::span<const Eigen::Vector3d> goals_m,
    std::span<const KeepOutZone> zones, double snap_tolerance_m, const TravelCostConfig& config,
    const std::function<bool()>& should_stop) {
  Expected<TravelCostQuery> query = TravelCostQuery::Prepare(
      graph, profile, starts_m, goals_m, zones, snap_tolerance_m, config, should_stop);
  if (!query) return std::move(query).error();
  TravelCostMatrix matrix = query->InitialMatrix();
  TravelCostWorkspace workspace;
  for (int k = 0; k < query->search_count(); ++k) {
    if (Status s = query->RunSearch(k, &workspace, &matrix, should_stop); !s) return s.error();
  }
  return matrix;
}

}  // namespace strata
