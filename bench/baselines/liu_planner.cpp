#include "baselines/liu_planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <queue>
#include <string>

#include "baselines/cloud_search.hpp"
#include "baselines/footprint_check.hpp"
#include "baselines/local_plane.hpp"

namespace strata::baselines {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

Status ValidateParams(const LiuParams& p) {
  auto bad = [](const std::string& what) { return Error{ErrorCode::kInvalidConfig, what}; };
  if (p.normal_neighbours < 3) return bad("LiuParams.normal_neighbours must be >= 3");
  if (!(p.max_roughness_m > 0)) return bad("LiuParams.max_roughness_m must be > 0");
  if (p.graph_neighbours < 1) return bad("LiuParams.graph_neighbours must be >= 1");
  if (!(p.max_edge_spacings > 1)) return bad("LiuParams.max_edge_spacings must be > 1");
  if (!(p.support_spacings >= 0)) return bad("LiuParams.support_spacings must be >= 0");
  if (!(p.weight_slope >= 0 && p.weight_roughness >= 0)) {
    return bad("LiuParams.weight_slope and weight_roughness must be >= 0");
  }
  if (!(p.snap_tolerance_m >= 0)) return bad("LiuParams.snap_tolerance_m must be >= 0");
  return Status::Ok();
}

}  // namespace

struct LiuPlanner::Impl {
  LiuParams params;
  BaselineRobot robot;
  LiuTimings timings;
  double spacing_m = 0;
  // Traversable points (graph nodes): ground position, tilt [rad], roughness [m].
  PointCloud nodes;
  std::vector<float> tilt, roughness;
  std::unique_ptr<CloudSearch> node_search;
  // Undirected k-NN graph in compressed rows: edges of node i are [offsets[i], offsets[i+1]).
  std::vector<std::size_t> offsets;
  std::vector<int> targets;
  std::vector<float> weights;
  std::vector<int> component;

  void ComputeComponents();
  // Snaps p (a reference point) to the nearest node; -1 beyond the tolerance.
  int Snap(const Eigen::Vector3d& p, double* distance_m) const;
};

void LiuPlanner::Impl::ComputeComponents() {
  component.assign(nodes.size(), -1);
  int label = 0;
  std::vector<int> stack;
  for (std::size_t seed = 0; seed < nodes.size(); ++seed) {
    if (component[seed] >= 0) continue;
    component[seed] = label;
    stack.assign(1, static_cast<int>(seed));
    while (!stack.empty()) {
      const int n = stack.back();
      stack.pop_back();
      for (std::size_t e = offsets[n]; e < offsets[n + 1]; ++e) {
        if (component[targets[e]] < 0) {
          component[targets[e]] = label;
          stack.push_back(targets[e]);
        }
      }
    }
    ++label;
  }
}

int LiuPlanner::Impl::Snap(const Eigen::Vector3d& p, double* distance_m) const {
  const Eigen::Vector3f ground =
      (p - Eigen::Vector3d(0, 0, robot.reference_height_m)).cast<float>();
  std::vector<int> indices;
  std::vector<float> squared;
  node_search->Nearest(ground, 1, &indices, &squared);
  if (indices.empty()) return -1;
  *distance_m = std::sqrt(static_cast<double>(squared[0]));
  return *distance_m <= params.snap_tolerance_m ? indices[0] : -1;
}

LiuPlanner::LiuPlanner(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LiuPlanner::~LiuPlanner() = default;

const LiuTimings& LiuPlanner::timings() const { return impl_->timings; }
std::size_t LiuPlanner::traversable_count() const { return impl_->nodes.size(); }
std::size_t LiuPlanner::edge_count() const { return impl_->targets.size() / 2; }
double LiuPlanner::point_spacing_m() const { return impl_->spacing_m; }

Expected<std::unique_ptr<LiuPlanner>> LiuPlanner::Build(const PointCloud& cloud,
                                                        const BaselineRobot& robot,
                                                        const LiuParams& params) {
  if (cloud.empty()) return Error{ErrorCode::kInvalidInput, "the cloud is empty"};
  if (Status s = ValidateParams(params); !s) return s.error();
  auto impl = std::make_unique<Impl>();
  impl->params = params;
  impl->robot = robot;
  // Read by the `#pragma omp` loops only, so unused in a build without OpenMP.
  [[maybe_unused]] const int threads = params.num_threads > 0 ? params.num_threads : 0;
  const long n = static_cast<long>(cloud.size());

  // 1. Local structure: PCA of every point's k-neighbourhood.
  auto start = Clock::now();
  const CloudSearch search(cloud);
  impl->spacing_m = search.MedianSpacing();
  std::vector<LocalPlane> planes(cloud.size());
#pragma omp parallel num_threads(threads) if (threads != 1)
  {
    std::vector<int> indices;
    std::vector<float> squared;
#pragma omp for schedule(dynamic, 1024)
    for (long i = 0; i < n; ++i) {
      search.Nearest(cloud[i], params.normal_neighbours, &indices, &squared);
      planes[i] = FitLocalPlane(cloud, indices);
    }
  }
  impl->timings.normals_s = SecondsSince(start);

  // 2. Traversable points: gentle, smooth, ground under the footprint, body column free.
  start = Clock::now();
  const double support_radius =
      std::max(robot.footprint_radius_m, params.support_spacings * impl->spacing_m);
  const double query_radius = CheckFootprintQueryRadius(robot, support_radius);
  const float lift = static_cast<float>(CheckFootprintCenterLift(robot, support_radius));
  std::vector<char> traversable(cloud.size(), 0);
#pragma omp parallel num_threads(threads) if (threads != 1)
  {
    std::vector<int> indices;
    PointCloud neighbours;
#pragma omp for schedule(dynamic, 1024)
    for (long i = 0; i < n; ++i) {
      const LocalPlane& plane = planes[i];
      if (!plane.valid || plane.tilt_rad() > robot.max_tilt_rad ||
          plane.roughness_m > params.max_roughness_m) {
        continue;
      }
      search.Radius(cloud[i] + Eigen::Vector3f(0, 0, lift), query_radius, &indices);
      neighbours.clear();
      for (const int j : indices) neighbours.push_back(cloud[j]);
      traversable[i] =
          CheckFootprint(cloud[i], plane.normal, neighbours, robot, support_radius).ok();
    }
  }
  for (long i = 0; i < n; ++i) {
    if (!traversable[i]) continue;
    impl->nodes.push_back(cloud[i]);
    impl->tilt.push_back(planes[i].tilt_rad());
    impl->roughness.push_back(planes[i].roughness_m);
  }
  impl->timings.traversability_s = SecondsSince(start);
  if (impl->nodes.empty()) {
    return Error{ErrorCode::kNoPath, "no point of the cloud is traversable for the robot"};
  }

  // 3. k-NN graph over the traversable points, weighted by the terrain metric
  //    length × (1 + w_s·mean tilt/θ + w_r·mean roughness/bound); an edge must also pass the
  //    step rule |Δz| <= step + horizontal length·tanθ.
  start = Clock::now();
  impl->node_search = std::make_unique<CloudSearch>(impl->nodes);
  const long m = static_cast<long>(impl->nodes.size());
  const float max_edge = static_cast<float>(params.max_edge_spacings * impl->spacing_m);
  const float tan_tilt = static_cast<float>(std::tan(robot.max_tilt_rad));
  std::vector<std::vector<std::pair<int, float>>> out(impl->nodes.size());
#pragma omp parallel num_threads(threads) if (threads != 1)
  {
    std::vector<int> indices;
    std::vector<float> squared;
#pragma omp for schedule(dynamic, 1024)
    for (long i = 0; i < m; ++i) {
      impl->node_search->Nearest(impl->nodes[i], params.graph_neighbours + 1, &indices, &squared);
      for (std::size_t k = 0; k < indices.size(); ++k) {
        const int j = indices[k];
        if (j == i) continue;
        const Eigen::Vector3f d = impl->nodes[j] - impl->nodes[i];
        const float length = std::sqrt(squared[k]);
        if (length > max_edge) continue;
        if (std::abs(d.z()) > robot.max_step_m + d.head<2>().norm() * tan_tilt) continue;
        const double slope = 0.5 * (impl->tilt[i] + impl->tilt[j]) / robot.max_tilt_rad;
        const double rough =
            0.5 * (impl->roughness[i] + impl->roughness[j]) / params.max_roughness_m;
        out[i].emplace_back(j, static_cast<float>(length * (1 + params.weight_slope * slope +
                                                            params.weight_roughness * rough)));
      }
    }
  }
  // Symmetrise: the k-NN relation is not symmetric, the graph is.
  std::vector<std::vector<std::pair<int, float>>> adjacency(impl->nodes.size());
  for (long i = 0; i < m; ++i) {
    for (const auto& [j, w] : out[i]) {
      adjacency[i].emplace_back(j, w);
      adjacency[j].emplace_back(static_cast<int>(i), w);
    }
  }
  impl->offsets.assign(impl->nodes.size() + 1, 0);
  for (long i = 0; i < m; ++i) {
    auto& list = adjacency[i];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end(),
                           [](const auto& a, const auto& b) { return a.first == b.first; }),
               list.end());
    impl->offsets[i + 1] = impl->offsets[i] + list.size();
  }
  impl->targets.reserve(impl->offsets.back());
  impl->weights.reserve(impl->offsets.back());
  for (const auto& list : adjacency) {
    for (const auto& [j, w] : list) {
      impl->targets.push_back(j);
      impl->weights.push_back(w);
    }
  }
  impl->ComputeComponents();
  impl->timings.graph_s = SecondsSince(start);
  impl->timings.total_s =
      impl->timings.normals_s + impl->timings.traversability_s + impl->timings.graph_s;
  return std::unique_ptr<LiuPlanner>(new LiuPlanner(std::move(impl)));
}

Expected<BaselinePath> LiuPlanner::Plan(const Eigen::Vector3d& start_m,
                                        const Eigen::Vector3d& goal_m, double time_limit_s) const {
  const auto begin = Clock::now();
  const Impl& g = *impl_;
  BaselinePath path;
  const int source = g.Snap(start_m, &path.start_snap_m);
  if (source < 0) {
    return Error{ErrorCode::kStartOffGround, "no traversable point within " +
                                                 std::to_string(g.params.snap_tolerance_m) +
                                                 " m of the start"};
  }
  const int target = g.Snap(goal_m, &path.goal_snap_m);
  if (target < 0) {
    return Error{ErrorCode::kGoalOffGround, "no traversable point within " +
                                                std::to_string(g.params.snap_tolerance_m) +
                                                " m of the goal"};
  }
  if (g.component[source] != g.component[target]) {
    return Error{ErrorCode::kGoalUnreachable, "start and goal lie in different components"};
  }

  // Plain Dijkstra (no heuristic, as in the published method), stopped when the goal settles.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> distance(g.nodes.size(), kInf);
  std::vector<int> previous(g.nodes.size(), -1);
  using Entry = std::pair<float, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  distance[source] = 0;
  open.emplace(0.f, source);
  long pops = 0;
  while (!open.empty()) {
    const auto [d, n] = open.top();
    open.pop();
    if (d > distance[n]) continue;
    if (n == target) break;
    if ((++pops & 1023) == 0 && SecondsSince(begin) > time_limit_s) {
      return Error{ErrorCode::kDeadlineExceeded, "Dijkstra ran out of its time limit"};
    }
    for (std::size_t e = g.offsets[n]; e < g.offsets[n + 1]; ++e) {
      const float candidate = d + g.weights[e];
      if (candidate < distance[g.targets[e]]) {
        distance[g.targets[e]] = candidate;
        previous[g.targets[e]] = n;
        open.emplace(candidate, g.targets[e]);
      }
    }
  }
  if (!std::isfinite(distance[target])) {
    return Error{ErrorCode::kNoPath, "Dijkstra did not reach the goal"};
  }
  const Eigen::Vector3d lift(0, 0, g.robot.reference_height_m);
  for (int n = target; n >= 0; n = previous[n]) {
    path.points_m.push_back(g.nodes[n].cast<double>() + lift);
  }
  std::reverse(path.points_m.begin(), path.points_m.end());
  return path;
}

}  // namespace strata::baselines
