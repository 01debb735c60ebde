#pragma once
/// Travel-cost matrices for fleet dispatchers: from each of N starts to each of M goals on one
/// map, whether a robot can get there and, if so, about how long the drive takes and how long
/// it is, in one graph search per start instead of one plan per pair.
///
/// - Ends: starts and goals snap as Plan snaps them (SnapEndpoint, the same tolerance,
///   clearance from obstacles and failures) and are checked against the keep-out zones as Plan
///   checks them.
/// - Reachability is Plan's: ends in different connected components of the SurfaceGraph are
///   unreachable at once; keep-out zones take their nodes out of the search, as they do for
///   Plan's A*, so a goal only they cut off is unreachable too.
/// - Search: one multi-goal Dijkstra per search source over a coarse view of the SurfaceGraph
///   (TravelCostConfig::coarse_cell_m), with the edge costs of Plan's A* (EdgeCost), stopping
///   once every goal it can reach is settled. The searches run from the smaller side (starts,
///   or goals when there are fewer): the graph is undirected and the time model symmetric.
/// - Time: along each path, smoothed over TravelCostConfig::smoothing_m, the time-optimal
///   speed profile from rest to rest under the profile's bounds scaled by limit_margin
///   (EstimateTravelTime), which is what the optimiser aims at; no constant is fitted to the
///   durations Plan returns.
///
/// The planner has no threads: a TravelCostQuery is immutable once prepared, and a caller
/// may run its searches on as many threads as it likes, each with its own workspace.
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/planning/keep_out.hpp"
#include "strata/planning/path_search.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/trajectory_costs.hpp"
#include "strata/planning/trajectory_optimizer.hpp"
#include "strata/status.hpp"
#include "strata/verification/trajectory_verifier.hpp"

namespace strata {

/// Settings of a travel-cost estimate; every tuning constant of the estimate is one of these.
/// Validate() blames the first bad field by its path, `path`.<field>.
struct TravelCostConfig {
  /// Edge costs, as Plan's A* prices moves (clearance and rim terms); max_expansions bounds
  /// each search (in search nodes); heuristic_weight and line_bias are not used (Dijkstra has
  /// no heuristic, and searches towards many goals at once).
  SearchConfig search;
  /// Edge of the square blocks of grid columns merged into one search node [m], >= 0: rounded
  /// to a whole number of grid cells, from 1 to 8; 0 (or anything under 1.5 cells) searches
  /// the SurfaceGraph itself, node for node as A* does. A block's nodes that connect inside it
  /// (per level) become one search node at the member nearest their mean, so reachability is
  /// exactly the SurfaceGraph's; lengths change by a fraction of a block. 0.4 m cuts the
  /// spiral's 125,000 nodes at 0.2 m fourfold and each search about as much.
  double coarse_cell_m = 0.4;
  /// Half-length of the window each path is smoothed over before its speed profile [m], >= 0.
  /// The trajectory cannot follow what is shorter than its pieces (OptimizerConfig's
  /// piece_length_m, the default here): it cuts the grid's zigzags and rounds corners.
  double smoothing_m = OptimizerConfig{}.piece_length_m;
  /// Fraction of the profile's acceleration bounds the trajectory uses [-], in (0, 1]: the
  /// optimiser's own margin (CostConfig::limit_margin, the default here).
  double limit_margin = CostConfig{}.limit_margin;
  /// Fraction of the profile's speed bounds the trajectory cruises at [-], in (0, 1]: the
  /// cruise speed of the optimiser's initial timing (OptimizerConfig::initial_speed_fraction,
  /// the default here), near which its trajectories stay: at 0.96, the median estimate of
  /// 500 random pairs per shared map is within 2% of Plan's duration (docs/benchmarks.md).
  double speed_fraction = OptimizerConfig{}.initial_speed_fraction;
  /// Least distance from obstacles of the reference point an end snaps to [m], >= 0: Plan's
  /// rule (SnapEndpoint), with the verifier's bound (VerifierConfig::min_obstacle_distance_m,
  /// the default here) that Plan uses unless a request sets its own.
  double min_obstacle_distance_m = VerifierConfig{}.min_obstacle_distance_m;
  /// Most SurfaceGraph nodes the components holding a start and a goal may hold [-], >= 1:
  /// an estimate's search graph takes about 25 bytes per node of them at the default
  /// coarse_cell_m on a 0.2 m map (90 searching node for node), so this bounds its memory
  /// (4,000,000 nodes: a 400 m × 400 m site at 0.2 m, about 100 MB). More fails with
  /// kResourceExhausted naming the limit.
  int max_nodes = 4'000'000;

  Status Validate(std::string_view path = "costs") const;
};

/// A time and length estimate along a path.
struct TravelTimeEstimate {
  double time_s = 0;    ///< From rest at the first point to rest at the last [s].
  double length_m = 0;  ///< Length of the smoothed path [m].
};

/// The time-optimal drive along `path_m` (3D points, e.g. a search path's reference points)
/// for `profile`, from rest to rest: the path is resampled every smoothing_m and averaged
/// over ±smoothing_m of arc length (ends fixed); each stretch may go no faster than
/// speed_fraction times the horizontal speed bound over its horizontal share and the vertical
/// bound over its vertical share (so the vertical bound slows steep slopes), and accelerate no
/// harder than limit_margin times the acceleration bounds likewise; each bend no faster than its
/// curvature κ allows, sqrt(limit_margin · a_max / κ), horizontally and vertically (changes of
/// slope). The speed profile is the fastest that meets these (forward and backward passes, exact
/// per stretch). Fewer than two distinct points give zero. `config.search`, `config.coarse_cell_m`
/// and `config.min_obstacle_distance_m` are not used.
TravelTimeEstimate EstimateTravelTime(std::span<const Eigen::Vector3d> path_m,
                                      const RobotProfile& profile, const TravelCostConfig& config);

/// One cell of a matrix: start i to goal j.
struct TravelCost {
  /// Why there is no estimate: kStartOffGround, kGoalOffGround, kStartInKeepOut,
  /// kGoalInKeepOut (the end's own failure, see TravelCostQuery::starts/goals), kGoalUnreachable
  /// (no way over connected ground, or keep-out zones close every way), kSearchBudgetExhausted
  /// (the search used search.max_expansions first). Unset when the goal is reachable.
  std::optional<ErrorCode> failure;
  double time_s = 0;           ///< Estimated drive from rest to rest [s] (EstimateTravelTime).
  double length_m = 0;         ///< Length of the smoothed path [m], the trajectory's estimate.
  double search_cost = 0;      ///< The path's cost in the search's metric (Σ EdgeCost) [m].
  double search_length_m = 0;  ///< Polyline length of the search path's nodes [m].

  bool reachable() const { return !failure.has_value(); }
};

/// N starts × M goals, row-major: cells[i · goal_count + j] is start i to goal j.
struct TravelCostMatrix {
  int start_count = 0;
  int goal_count = 0;
  std::vector<TravelCost> cells;

  const TravelCost& at(int start, int goal) const {
    return cells[static_cast<std::size_t>(start) * static_cast<std::size_t>(goal_count) +
                 static_cast<std::size_t>(goal)];
  }
  TravelCost& at(int start, int goal) {
    return cells[static_cast<std::size_t>(start) * static_cast<std::size_t>(goal_count) +
                 static_cast<std::size_t>(goal)];
  }
};

/// Work done by one search.
struct TravelSearchStats {
  int expansions = 0;  ///< Search nodes settled [-].
};

namespace internal {
struct CoarseGraph;
struct TravelSearchState;
}  // namespace internal

/// The scratch space of one thread's searches, kept between them so that a thread running
/// many searches allocates once. Not thread-safe: one per thread.
class TravelCostWorkspace {
 public:
  TravelCostWorkspace();
  ~TravelCostWorkspace();
  TravelCostWorkspace(TravelCostWorkspace&&) noexcept;
  TravelCostWorkspace& operator=(TravelCostWorkspace&&) noexcept;

 private:
  friend class TravelCostQuery;
  std::unique_ptr<internal::TravelSearchState> state_;
};

/// One estimate's ends, snapped and checked, and the graph its searches run on. Keeps a
/// reference to the SurfaceGraph, which must outlive it. Immutable once prepared: RunSearch
/// may run on any number of threads at once, with different searches and workspaces.
class TravelCostQuery {
 public:
  /// Snaps every start and goal (SnapEndpoint with `snap_tolerance_m` and
  /// config.min_obstacle_distance_m; the failure of one is that end's, not the call's), checks
  /// them against `zones` (the map's and the request's, valid, as Plan collects them) and
  /// builds the coarse graph of the components that hold a valid start and a valid goal,
  /// without the nodes the zones take (ends excepted). Fails with kInvalidInput (a non-finite
  /// end or tolerance, or no start or no goal), kInvalidConfig (`config`, blamed by its path),
  /// kResourceExhausted (those components hold more than config.max_nodes nodes), kCancelled
  /// (`should_stop`, polled every few thousand nodes and between ends).
  static Expected<TravelCostQuery> Prepare(const SurfaceGraph& graph, const RobotProfile& profile,
                                           std::span<const Eigen::Vector3d> starts_m,
                                           std::span<const Eigen::Vector3d> goals_m,
                                           std::span<const KeepOutZone> zones,
                                           double snap_tolerance_m, const TravelCostConfig& config,
                                           const std::function<bool()>& should_stop = {});
  ~TravelCostQuery();
  TravelCostQuery(TravelCostQuery&&) noexcept;
  TravelCostQuery& operator=(TravelCostQuery&&) noexcept;

  /// Where each start landed (position_m where a trajectory would start), or why it has no
  /// estimate: kStartOffGround (the message names the nearest ground) or kStartInKeepOut.
  const std::vector<Expected<SnapResult>>& starts() const { return starts_; }
  /// The same for the goals: kGoalOffGround or kGoalInKeepOut.
  const std::vector<Expected<SnapResult>>& goals() const { return goals_; }
  /// Nodes of the search graph [-] and the SurfaceGraph nodes they stand for [-].
  int search_node_count() const;
  int surface_node_count() const;

  /// The matrix with the cells decided without a search filled in (an end's own failure,
  /// ends in different components) and the rest reachable at 0 s until RunSearch fills them.
  TravelCostMatrix InitialMatrix() const;
  /// Searches to run: one per valid start that shares a component with a valid goal, or the
  /// same per goal when there are fewer such goals.
  int search_count() const { return static_cast<int>(sources_.size()); }
  /// Runs search `k` in [0, search_count()) and writes its cells of `matrix` (InitialMatrix's
  /// shape; each search writes a row or a column of its own, so searches on other threads may
  /// share the matrix). Fails only with kCancelled when `should_stop` (may be empty; polled
  /// every 1024 settled nodes and every few paths) returns true, leaving some of its cells as
  /// they were.
  Status RunSearch(int k, TravelCostWorkspace* workspace, TravelCostMatrix* matrix,
                   const std::function<bool()>& should_stop = {},
                   TravelSearchStats* stats = nullptr) const;

 private:
  TravelCostQuery() = default;

  const SurfaceGraph* graph_ = nullptr;
  RobotProfile profile_;
  TravelCostConfig config_;
  std::vector<Expected<SnapResult>> starts_;
  std::vector<Expected<SnapResult>> goals_;
  bool search_from_starts_ = true;  // Sources are starts (else goals, the matrix transposed).
  std::vector<int> sources_;        // Start (or goal) index of each search.
  std::vector<int> start_nodes_;    // Search node of each start, -1 when it has none.
  std::vector<int> goal_nodes_;
  std::shared_ptr<const internal::CoarseGraph> coarse_;
};

/// Prepares the query and runs every search in turn on this thread; fails as
/// TravelCostQuery::Prepare and RunSearch do. For a caller without threads, and for tests.
Expected<TravelCostMatrix> EstimateTravelCosts(
    const SurfaceGraph& graph, const RobotProfile& profile,
    std::span<const Eigen::Vector3d> starts_m, std::span<const Eigen::Vector3d> goals_m,
    std::span<const KeepOutZone> zones, double snap_tolerance_m, const TravelCostConfig& config,
    const std::function<bool()>& should_stop = {});

}  // namespace strata
