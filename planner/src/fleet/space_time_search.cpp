#include "space_time_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <unordered_map>
#include <utility>

#include <Eigen/Geometry>

namespace strata::fleet_internal {
namespace {

constexpr double kForever = std::numeric_limits<double>::infinity();
// Others' ways are swept in stretches this long [s]: each stretch marks the columns within
// reach of the segment between its ends, for the whole stretch.
constexpr double kSweepStepS = 0.25;
// should_stop is polled every this many expansions.
constexpr int kStopPollStates = 1024;

/// Another robot's way over a stretch of time: it moves from p0 to p1 (straight, as far as
/// the sweep is concerned) while its body takes the heights [bottom_m, top_m].
struct Sweep {
  double from_s = 0;
  double to_s = 0;
  Eigen::Vector2d p0 = Eigen::Vector2d::Zero();
  Eigen::Vector2d p1 = Eigen::Vector2d::Zero();
  double reach_m = 0;  ///< The two bodies' radii, the separation and the margin [m].
  double bottom_m = 0;
  double top_m = 0;

  /// The segment's box widened by its reach: the points it may reach lie inside.
  Eigen::AlignedBox2d ReachBox() const {
    return {p0.cwiseMin(p1).array() - reach_m, p0.cwiseMax(p1).array() + reach_m};
  }
};

struct SafeInterval {
  double from_s = 0;
  double to_s = kForever;
};

/// Where another robot is at one moment: its reference point and its body's heights.
struct WayPoint {
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  VerticalExtent extent;
};

/// The others' ways from the departure on, up to the horizon, in stretches of kSweepStepS,
/// filed by the square buckets of the plane they reach into, so that a node looks only at
/// the stretches of its bucket.
class OthersWays {
 public:
  OthersWays(const Traffic& traffic, const SpaceTimeOptions& options) {
    for (const ReservedMotion& reserved : traffic.others) {
      const FleetMotion& other = reserved.motion;
      const double reach_m = traffic.body.radius_m + other.body.radius_m +
                             PairSeparationM(traffic.rule, other) + options.margin_m;
      const double begin_s = std::max(0.0, SecondsBetween(traffic.departure_ns, other.start_ns));
      const double arrival_s = SecondsBetween(traffic.departure_ns, other.ArrivalNs());
      const double end_s =
          std::min(options.horizon_s, SecondsBetween(traffic.departure_ns, other.end_ns));
      // The way is read at non-decreasing times along one cursor, each stretch's end once
      // (it is the next stretch's start): reading each point anew, from the trajectory's
      // first piece, took a third of filing the ways.
      TrajectoryCursor cursor(other.trajectory);
      double read_s = -1;
      WayPoint read_point;
      const auto read = [&](double time_s) {
        if (time_s != read_s) {
          const std::int64_t time_ns = AddSeconds(traffic.departure_ns, time_s);
          const StateVector state = cursor.Evaluate(other.TrajectoryTimeAt(time_ns), 0);
          read_s = time_s;
          read_point = {state.head<2>(), other.ExtentOf(state)};
        }
        return read_point;
      };
      const auto sweep = [&](double from_s, double to_s) {
        const WayPoint from = read(from_s);
        const WayPoint to = read(to_s);
        File(Sweep{from_s, to_s, from.p, to.p, reach_m,
                   std::min(from.extent.bottom_m, to.extent.bottom_m),
                   std::max(from.extent.top_m, to.extent.top_m)});
      };
      for (double t = begin_s; t < std::min(arrival_s, end_s); t += kSweepStepS) {
        sweep(t, std::min({t + kSweepStepS, arrival_s, end_s}));
      }
      if (end_s > std::max(begin_s, arrival_s)) sweep(std::max(begin_s, arrival_s), end_s);
    }
  }

  /// Calls f(sweep) for the stretches that may reach the point `p` with a body between the
  /// heights `bottom_m` and `top_m` (a superset; one may come twice).
  template <typename F>
  void ForEachNear(const Eigen::Vector2d& p, double bottom_m, double top_m, F&& f) const {
    for (std::int64_t bz = Bucket(bottom_m); bz <= Bucket(top_m); ++bz) {
      const auto found = buckets_.find(Key(Bucket(p.x()), Bucket(p.y()), bz));
      if (found == buckets_.end()) continue;
      for (const std::int32_t k : found->second) f(sweeps_[static_cast<std::size_t>(k)]);
    }
  }

 private:
  // Buckets are cubes: on a multi-storey site the floors' robots are filed apart.
  static constexpr double kBucketM = 2.0;
  static std::int64_t Bucket(double v) {
    return static_cast<std::int64_t>(std::floor(v / kBucketM));
  }
  static std::int64_t Key(std::int64_t bx, std::int64_t by, std::int64_t bz) {
    constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;
    return ((bx & kMask) << 42) | ((by & kMask) << 21) | (bz & kMask);
  }

  void File(const Sweep& sweep) {
    const Eigen::AlignedBox2d box = sweep.ReachBox();
    const Eigen::Vector2d& lo = box.min();
    const Eigen::Vector2d& hi = box.max();
    const auto k = static_cast<std::int32_t>(sweeps_.size());
    sweeps_.push_back(sweep);
    for (std::int64_t bz = Bucket(sweep.bottom_m); bz <= Bucket(sweep.top_m); ++bz) {
      for (std::int64_t by = Bucket(lo.y()); by <= Bucket(hi.y()); ++by) {
        for (std::int64_t bx = Bucket(lo.x()); bx <= Bucket(hi.x()); ++bx) {
          buckets_[Key(bx, by, bz)].push_back(k);
        }
      }
    }
  }

  // Each stretch once, the buckets listing indices into it. Filing a copy of the stretch (80
  // bytes) into each bucket it reaches made filing the ways 4.5 times slower and the search
  // after it a fifth slower (spiral, 50 robots: 0.60 and 2.55 s against 0.13 and 2.06 s).
  std::vector<Sweep> sweeps_;
  std::unordered_map<std::int64_t, std::vector<std::int32_t>> buckets_;
};

/// Whether a stretch's segment passes within its reach of `c`, horizontally.
bool Reaches(const Sweep& sweep, const Eigen::Vector2d& c) {
  // Most stretches filed with a node's bucket pass out of its reach (about four in five on the
  // spiral at 50 robots): the segment's box, widened by the reach, turns them away before the
  // projection and its division (the space-time search 16% faster, the same routes).
  if (!sweep.ReachBox().contains(c)) return false;
  const double r = sweep.reach_m;
  const Eigen::Vector2d ab = sweep.p1 - sweep.p0;
  const double ab2 = ab.squaredNorm();
  const double u = ab2 > 0 ? std::clamp((c - sweep.p0).dot(ab) / ab2, 0.0, 1.0) : 0.0;
  return (sweep.p0 + u * ab - c).squaredNorm() <= r * r;
}

/// A search state: a node within one of its safe intervals, reached at `arrival_s`.
struct State {
  int node = 0;
  SafeInterval interval;
  double arrival_s = kForever;
  double travel_s = 0;  ///< Of arrival_s, the time spent moving [s].
  int parent = -1;
  bool closed = false;
};

class SpaceTimeSearch {
 public:
  SpaceTimeSearch(const SurfaceGraph& graph, int goal_node, const Traffic& traffic,
                  const SpaceTimeOptions& options, const std::function<bool(int)>& blocked)
      : graph_(graph),
        goal_node_(goal_node),
        goal_(graph.position(goal_node)),
        traffic_(traffic),
        options_(options),
        blocked_(blocked),
        ways_(traffic, options),
        first_state_(static_cast<std::size_t>(graph.node_count()), kUnseen),
        state_count_(static_cast<std::size_t>(graph.node_count()), 0) {}

  std::optional<SpaceTimeRoute> Run(int start_node, const std::function<bool()>& should_stop) {
    const auto [first, count] = StatesOf(start_node);
    if (count == 0 || states_[static_cast<std::size_t>(first)].interval.from_s > 0) {
      return std::nullopt;
    }
    // A route ends in the goal's last safe interval, which must last (the robot stays there):
    // a goal busy up to the horizon has none, and the search would expand everything the wait
    // allows before it found so (11% of a 50-robot spiral run's expansions).
    const auto [goal_first, goal_count] = StatesOf(goal_node_);
    if (goal_count == 0 ||
        states_[static_cast<std::size_t>(goal_first + goal_count - 1)].interval.to_s != kForever) {
      return std::nullopt;
    }
    Reach(first, 0.0, 0.0, -1);
    int expansions = 0;
    while (!open_.empty()) {
      const auto [f, index] = open_.top();
      open_.pop();
      State& state = states_[static_cast<std::size_t>(index)];
      if (state.closed) continue;
      state.closed = true;
      if (++expansions > options_.max_states) return std::nullopt;
      if (expansions % kStopPollStates == 0 && should_stop && should_stop()) return std::nullopt;
      if (state.node == goal_node_ && state.interval.to_s == kForever) {
        SpaceTimeRoute route = RouteTo(index);
        route.expansions = expansions;
        return route;
      }
      Expand(index);
    }
    return std::nullopt;
  }

 private:
  static constexpr int kUnseen = -1;

  /// The time margin around a moment `t_s` after the departure: the route's timing drifts
  /// from the trajectory's as it goes.
  double Margin(double t_s) const {
    return options_.time_margin_s + options_.time_drift * std::max(0.0, t_s);
  }

  /// The states of `node`, one per safe interval (first index, count), made the first time:
  /// the times another robot's body reaches the node's column at its height (widened by the
  /// time margin), left out of [0, forever).
  std::pair<int, int> StatesOf(int node) {
    const auto n = static_cast<std::size_t>(node);
    if (first_state_[n] != kUnseen) return {first_state_[n], state_count_[n]};
    const Eigen::Vector3d at = graph_.position(node);
    const double bottom = graph_.ground_z(node);
    const double top = bottom + traffic_.body.height_m;
    taken_.clear();
    ways_.ForEachNear(at.head<2>(), bottom, top, [&](const Sweep& sweep) {
      if (sweep.top_m > bottom && top > sweep.bottom_m && Reaches(sweep, at.head<2>())) {
        const double from_s = sweep.from_s - Margin(sweep.from_s);
        const double to_s = sweep.to_s + Margin(sweep.to_s);
        // A robot's stretches come in the order of its way, and with margins wider than a
        // stretch each overlaps the last: kept as one busy time per passage instead of one
        // per stretch, they leave little to sort (sorting was a quarter of StatesOf). The same
        // union of busy times either way.
        if (!taken_.empty() && taken_.back().first <= from_s && from_s <= taken_.back().second) {
          taken_.back().second = std::max(taken_.back().second, to_s);
        } else {
          taken_.emplace_back(from_s, to_s);
        }
      }
    });
    std::sort(taken_.begin(), taken_.end());
    const int first = static_cast<int>(states_.size());
    double free_from = 0;
    const auto add = [&](double from_s, double to_s) {
      State state;
      state.node = node;
      state.interval = {from_s, to_s};
      states_.push_back(state);
    };
    for (const auto& [from, to] : taken_) {
      if (from > free_from) add(free_from, from);
      free_from = std::max(free_from, to);
    }
    // A node busy up to the horizon stays busy (the horizon is the end of what is known).
    if (free_from < options_.horizon_s) add(free_from, kForever);
    first_state_[n] = first;
    state_count_[n] = static_cast<int>(states_.size()) - first;
    return {first, state_count_[n]};
  }

  double Heuristic(int node) const {
    const double bound = std::max((graph_.position(node) - goal_).norm(),
                                  graph_.LandmarkBound(node, goal_node_, options_.terms));
    return options_.heuristic_weight * bound / options_.cost_per_s;
  }

  void Reach(int index, double arrival_s, double travel_s, int parent) {
    State& state = states_[static_cast<std::size_t>(index)];
    if (state.closed || state.arrival_s <= arrival_s) return;
    state.arrival_s = arrival_s;
    state.travel_s = travel_s;
    state.parent = parent;
    open_.emplace(arrival_s + Heuristic(state.node), index);
  }

  void Expand(int index) {
    // A copy: StatesOf appends to states_ as the neighbours are first reached.
    const State from = states_[static_cast<std::size_t>(index)];
    graph_.ForEachNeighbor(from.node, [&](int next) {
      if (blocked_ && next != goal_node_ && blocked_(next)) return;
      const double move_s = graph_.MoveCost(from.node, next, options_.terms) / options_.cost_per_s;
      const auto [first, count] = StatesOf(next);
      for (int k = first; k < first + count; ++k) {
        const SafeInterval interval = states_[static_cast<std::size_t>(k)].interval;
        // Leaving as late as its own interval allows, the robot arrives too early for this one.
        if (interval.from_s > from.interval.to_s + move_s) break;
        const double arrival_s = std::max(from.arrival_s + move_s, interval.from_s);
        if (arrival_s > interval.to_s || arrival_s > options_.horizon_s) continue;
        const double travel_s = from.travel_s + move_s;
        if (arrival_s - travel_s > options_.max_wait_s) continue;
        Reach(k, arrival_s, travel_s, index);
      }
    });
  }

  SpaceTimeRoute RouteTo(int index) const {
    std::vector<int> chain;
    for (int i = index; i >= 0; i = states_[static_cast<std::size_t>(i)].parent) {
      chain.push_back(i);
    }
    std::reverse(chain.begin(), chain.end());
    SpaceTimeRoute route;
    for (std::size_t k = 0; k < chain.size(); ++k) {
      const State& s = states_[static_cast<std::size_t>(chain[k])];
      route.nodes.push_back(s.node);
      double leave_s = s.arrival_s;
      if (k + 1 < chain.size()) {
        const State& next = states_[static_cast<std::size_t>(chain[k + 1])];
        leave_s = next.arrival_s - (next.travel_s - s.travel_s);
      }
      route.leave_s.push_back(leave_s);
      route.wait_s.push_back(leave_s - s.arrival_s);
    }
    return route;
  }

  const SurfaceGraph& graph_;
  int goal_node_;
  Eigen::Vector3d goal_;
  const Traffic& traffic_;
  const SpaceTimeOptions& options_;
  const std::function<bool(int)>& blocked_;
  OthersWays ways_;
  std::vector<int> first_state_;  // Per node, its first state, or kUnseen.
  std::vector<int> state_count_;  // Per node seen, its states.
  std::vector<State> states_;
  std::vector<std::pair<double, double>> taken_;  // Scratch of StatesOf.
  std::priority_queue<std::pair<double, int>, std::vector<std::pair<double, int>>, std::greater<>>
      open_;
};

}  // namespace

std::optional<SpaceTimeRoute> SearchSpaceTime(const SurfaceGraph& graph, int start_node,
                                              int goal_node, const Traffic& traffic,
                                              const SpaceTimeOptions& options,
                                              const std::function<bool(int)>& blocked,
                                              const std::function<bool()>& should_stop) {
  return SpaceTimeSearch(graph, goal_node, traffic, options, blocked).Run(start_node, should_stop);
}

}  // namespace strata::fleet_internal
