#pragma once
/// The whole planning pipeline for one request: snap start and goal, search (A*), optimise
/// (MINCO + L-BFGS), verify. A PlanningMap wraps an assessed TerrainModel and caches one
/// SurfaceGraph per robot traversability, so concurrent requests on one map share everything
/// read-only; Plan itself keeps no state between calls.
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/graph_archive.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/path_search.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/planning/trajectory_optimizer.hpp"
#include "strata/prism.hpp"
#include "strata/status.hpp"
#include "strata/verification/trajectory_verifier.hpp"

namespace strata {

/// An assessed map ready for planning, with the map's own keep-out zones. Thread-safe: any
/// number of Plan calls may share one.
class PlanningMap {
 public:
  /// `keep_out`: zones every plan on this map avoids (keep_out.hpp defines when a robot is in
  /// one), each valid (Prism::Validate; whoever makes them validates them, e.g. a map edit).
  /// They are not part of the graphs: a plan filters its search by them, so a map's zones and
  /// a request's cost alike. `max_graph_bytes` [bytes], >= 0, bounds the graphs kept (0: no
  /// bound): past it, the least recently used graphs no plan holds are dropped (and built
  /// again when asked for), the one just asked for always kept. Every robot profile, inline
  /// ones from any client included, has its own graph, so an unbounded cache would grow
  /// with the profiles clients make up. `archive` (may be null): where a graph is looked for
  /// before it is built, and kept once built.
  explicit PlanningMap(std::shared_ptr<const TerrainModel> model, std::vector<Prism> keep_out = {},
                       std::size_t max_graph_bytes = 0,
                       std::shared_ptr<const GraphArchive> archive = nullptr);
  const TerrainModel& model() const { return *model_; }
  const std::shared_ptr<const TerrainModel>& model_ptr() const { return model_; }
  /// The map's keep-out zones, as given.
  const std::vector<Prism>& keep_out() const { return keep_out_; }
  /// A planning map of the same model with `keep_out` instead of these zones, holding the
  /// graphs built here (zones are not part of them) under the same bound and archive: a map
  /// whose zones change plans at once, without building its graphs again.
  std::shared_ptr<const PlanningMap> WithKeepOut(std::vector<Prism> keep_out) const;
  /// The graph for `params`, found in the archive or built on first use (and then kept in
  /// the archive) (the first caller for these params builds,
  /// later ones for the same params wait; other params and MemoryBytes never wait for it)
  /// and kept while max_graph_bytes allows. Fails as SurfaceGraph::Build does (a failure is
  /// not kept: the next call tries again). `should_stop` (may be empty) stops the build this
  /// call makes, failing with kCancelled; a caller that was waiting for a build another
  /// caller stopped builds the graph itself.
  Expected<std::shared_ptr<const SurfaceGraph>> Graph(
      const TraversabilityParams& params, const std::function<bool()>& should_stop = {}) const;
  /// Graph, for a map whose model differs from `base`'s only in `changed_columns` (an edit's
  /// Reassessment::changed_columns): a graph `base` holds built for `params` is patched
  /// (SurfaceGraph::Patch) instead of building one, a tenth of the time on a site. The archive
  /// is then not looked in, since a patch is faster than a load too (1 km site: 0.6 s against
  /// 1.6 s), and the patched graph is kept there only when it holds none. As Graph when `base`
  /// holds none.
  Expected<std::shared_ptr<const SurfaceGraph>> GraphPatchedFrom(
      const PlanningMap& base, const CellBox& changed_columns, const TraversabilityParams& params,
      const std::function<bool()>& should_stop = {}) const;
  /// Makes here, ahead of any plan, the graphs of the robots that planned on `base` (its
  /// BuiltGraphParams, the `max_graphs` most recently used): patched from base's
  /// (GraphPatchedFrom) when `changed_columns` says where the models differ, built when it is
  /// null (they may differ anywhere). A failure is left to the first plan, which makes the
  /// graph again. Returns how many graphs were asked for; stops early as Graph does.
  std::size_t MakeGraphsAhead(const PlanningMap& base, const CellBox* changed_columns,
                              std::size_t max_graphs,
                              const std::function<bool()>& should_stop = {}) const;
  /// Bytes held by the model and the graphs kept.
  std::size_t MemoryBytes() const;
  /// The bytes of the model's arrays and the graphs that `made_from` (the version this one
  /// was made from) does not share with this map: what making it allocated; all of
  /// MemoryBytes when `made_from` is null (made from nothing).
  std::size_t MemoryBytesBeyond(const PlanningMap* made_from) const;
  /// Graphs kept (built, or being built).
  std::size_t GraphCount() const;
  /// The params of the graphs built and kept, most recently used first: the robots that plan
  /// on this map (a new version of it builds theirs before it is published).
  std::vector<TraversabilityParams> BuiltGraphParams() const;

 private:
  struct GraphEntry;  // One graph's build, done once.
  // How a graph missing from the archive is made: built, or patched from another map's.
  using GraphMaker =
      std::function<Expected<SurfaceGraph>(const std::function<bool()>& should_stop)>;
  // Whether a graph made by a GraphMaker is looked for in the archive first (a build: a load
  // is faster) or not (a patch: faster than a load).
  enum class Archived { kLookFirst, kMakeFirst };
  // Graph and GraphPatchedFrom: the graph for `params`, made by `make` when no call made it.
  Expected<std::shared_ptr<const SurfaceGraph>> GraphMadeBy(
      const TraversabilityParams& params, const std::function<bool()>& should_stop,
      Archived archived, const GraphMaker& make) const;
  // One try of GraphMadeBy: *built_here tells whether this call ran the build.
  Expected<std::shared_ptr<const SurfaceGraph>> GraphOnce(const TraversabilityParams& params,
                                                          const std::function<bool()>& should_stop,
                                                          Archived archived, const GraphMaker& make,
                                                          bool* built_here) const;
  // The graph for `params` if one is built and kept here, else null.
  std::shared_ptr<const SurfaceGraph> BuiltGraph(const TraversabilityParams& params) const;
  // Drops the least recently used graphs no plan holds until the kept ones fit
  // max_graph_bytes_, never the most recently used; call with mutex_.
  void DropGraphsLocked() const;

  std::shared_ptr<const TerrainModel> model_;
  std::vector<Prism> keep_out_;
  const std::size_t max_graph_bytes_;
  const std::shared_ptr<const GraphArchive> archive_;
  mutable std::mutex mutex_;  // Guards the two below, never held while a graph builds.
  // Keyed by the whole TraversabilityParams (its operator<=>): a field added there is part of
  // the key. Only valid params enter, so no NaN breaks the ordering.
  mutable std::map<TraversabilityParams, std::shared_ptr<GraphEntry>> graphs_;
  mutable std::list<TraversabilityParams> recency_;  // Keys of graphs_, most recent first.
};

/// Per-request options. Validate() blames the first bad field by its path, `path`.<field>
/// (e.g. "options.optimizer.weights.safety").
struct PlanOptions {
  /// Wall-clock budget of the whole plan [s], > 0. Running out fails with kDeadlineExceeded.
  double time_budget_s = 2.0;
  /// How far start and goal may be from traversable ground (3D, to the reference point) [m].
  double snap_tolerance_m = 1.0;
  SearchConfig search;        ///< A* settings (it runs on the plan's time budget).
  OptimizerConfig optimizer;  ///< Weights, thresholds, L-BFGS settings.
  VerifierConfig verifier;    ///< Tolerances of the final check.
  /// Optimisations to try before giving up [-], in [1, 10]. After a failed verification the
  /// next attempt stiffens the penalties: the obstacle distance's stiffness and the edge,
  /// ground, feasibility and keep-out weights ×4, the ground's dead band ×0.25, the piece
  /// length ×0.7 (more constraint points), the limit margin ×0.95 and the initial speed ×0.75
  /// (Plan in planner/src/planner.cpp). When every attempt fails, the slow
  /// fallback is tried (PlanStats::fallback).
  int max_attempts = 3;
  Status Validate(std::string_view path = "options") const;
};

/// Most pieces a warm start's trajectory may have.
inline constexpr std::size_t kMaxWarmStartPieces = kMaxTrajectoryPieces;

/// A point a route passes through between start and goal (PlanRequest::via).
struct Via {
  /// Where [m], map frame; snapped as the goal is (SnapEndpoint, the same tolerance).
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  /// True: the robot comes to rest there (the route is planned in legs between stops, each
  /// from rest to rest). False: it flows through at speed (a waypoint the optimiser keeps
  /// fixed, OptimizationProblem::pinned_waypoints).
  bool stop = false;
};

/// Most vias one request may carry: each adds a search, and each stop a whole leg's plan. A
/// fleet plan holds a space-time route to its way with points spread over it, as many as
/// kMaxVias leaves beside the stops the plan may add (at 16, routes past about 100 m were
/// unguided beyond it).
inline constexpr int kMaxVias = 64;

struct PlanRequest {
  RobotState start;
  RobotState goal;
  RobotProfile profile;
  PlanOptions options;
  /// Zones this plan must keep the robot out of besides the map's (keep_out.hpp defines when
  /// a robot is in one; e.g. where another robot is parked), at most kMaxRequestKeepOutZones.
  std::vector<Prism> keep_out;
  /// The trajectory the robot is following, when it replans on the way: the optimiser starts
  /// from its remainder (MakeWarmProblem) instead of searching, and the plan falls back to a
  /// search when the remainder does not fit (the start or goal moved more than
  /// kWarmStartToleranceM from it) or does not pass verification.
  /// Ignored when `via` is not empty (a route is planned from scratch).
  std::optional<WarmStart> warm_start;
  /// Points the trajectory passes through in this order between start and goal, at most
  /// kMaxVias. PlanResult::via_times_s says when each is reached.
  std::vector<Via> via;
  /// The first bad field of start, goal, profile, options, keep_out, warm_start or via, blamed
  /// by its path (e.g. "start.position_m.x", "profile.max_tilt_rad", "options.max_attempts",
  /// "keep_out[1].polygon_m[2].x", "via[0].position_m.z"): kInvalidInput for a non-finite
  /// state, a malformed zone, more than kMaxRequestKeepOutZones zones ("keep_out") or more
  /// than kMaxVias vias ("via"), kInvalidConfig for a field out of range.
  Status Validate() const;
};

/// Wall-clock seconds per stage of one plan.
struct PlanTimings {
  /// The robot's surface graph: looked up, or built the first time a profile plans on the
  /// map (then usually the largest stage).
  double graph_s = 0;
  double snap_s = 0;      ///< Snapping the start, the goal and the vias onto the graph.
  double search_s = 0;    ///< A*.
  double optimize_s = 0;  ///< MINCO + L-BFGS (all attempts).
  double verify_s = 0;    ///< Dense verification (all attempts).
  double total_s = 0;
};

/// Figures of a successful plan (paper Table 2 and the verification's extremes).
struct PlanStats {
  double length_m = 0;    ///< Arc length of the reference point's path [m].
  double duration_s = 0;  ///< Total duration [s].
  /// Mean curvature κ_m [1/m]: the mean of ‖p′×p″‖/‖p′‖³ over uniform time samples (paper
  /// Table 2), over the samples where the speed exceeds 1 cm/s.
  double mean_curvature_per_m = 0;
  double max_speed_horizontal_mps = 0;
  double max_speed_vertical_mps = 0;
  double max_accel_horizontal_mps2 = 0;
  double max_accel_vertical_mps2 = 0;
  double min_obstacle_distance_m = 0;  ///< Smallest ESDF d at the reference point [m].
  double max_ground_offset_m = 0;      ///< Largest |z − (ground + reference height)| [m].
  double max_tilt_rad = 0;             ///< Steepest ground under the trajectory [rad].
  double min_body_height_m = 0;        ///< Lowest commanded body height [m] (active only).
  double min_headroom_m = 0;           ///< Smallest ceiling clearance − body height [m].
  int pieces = 0;                      ///< MINCO pieces M.
  int search_expansions = 0;           ///< A* expansions.
  int optimizer_iterations = 0;        ///< L-BFGS iterations (all attempts).
  int optimizer_attempts = 0;          ///< Optimisations run (a failed verification retries).
  int verified_samples = 0;            ///< Samples checked by verification.
  /// Factor by which the optimised trajectory's durations were stretched to bring a speed or
  /// an acceleration within its bound (time_scaling.hpp) [-]; 1 when none was needed.
  double time_stretch = 1;
  /// True when the trajectory continues the request's warm start (no search ran).
  bool warm_started = false;
  /// True when no optimised trajectory passed verification and this one is the last resort:
  /// the searched path's own points, driven slowly (MakeFallbackProblem), verified like any
  /// other: the shortened path's, else the search's column-to-column path as found (then
  /// PlanResult::path). A dispatcher may prefer another robot or goal.
  bool fallback = false;
  /// With fallback: why the last optimised trajectory failed verification (its first
  /// violation), e.g. "horizontal acceleration 1.03 m/s^2 exceeds the bound 1 m/s^2 at ...".
  std::string fallback_reason;
  /// The dynamic bound the trajectory comes closest to: "horizontal_speed", "vertical_speed",
  /// "horizontal_acceleration" or "vertical_acceleration", the one whose peak is the largest
  /// fraction of the profile's bound. Where a trajectory takes longer than its length at the
  /// speed bound, this says what held it back (a slope's vertical speed, a turn's
  /// acceleration).
  std::string limiting_bound;
  double limiting_bound_fraction = 0;  ///< That peak over that bound [-].
  PlanTimings timings;
};

struct PlanResult {
  Trajectory trajectory;
  /// Where the start snapped, and its level. position_m is exactly where the trajectory
  /// starts: the requested x, y at the reference height above the ground when they lie in the
  /// snapped node's column (the robot is where it says), else that node's reference point.
  SnapResult start;
  SnapResult goal;  ///< Where the goal snapped; position_m is where the trajectory ends.
  /// Where each PlanRequest::via snapped, in its order; position_m is exactly where the
  /// trajectory passes (or stops).
  std::vector<SnapResult> via;
  PathResult path;  ///< The A* paths the trajectory was initialised from, joined.
  /// Per PlanRequest::via, in its order: the time from the trajectory's start at which the
  /// trajectory is at the via's snapped point [s] (after any time stretching).
  std::vector<double> via_times_s;
  PlanStats stats;
};

/// The keep-out zones a plan on `map` honours besides `request_zones` (valid, as
/// PlanRequest::Validate checks them): the map's, named "the map's keep-out zone <i>", then the
/// request's, named "keep-out zone keep_out[<i>]", as messages quote them.
std::vector<KeepOutZone> CollectKeepOut(const PlanningMap& map,
                                        std::span<const Prism> request_zones);

/// Checks a trajectory made elsewhere (by a robot's own planner, or planned before) on `map`
/// as Plan checks its own: VerifyTrajectory against `profile`'s graph (found or built as
/// Plan finds it; `should_stop`, may be empty, stops a build with kCancelled) and the map's
/// keep-out zones, under `config`. Fails as the profile's Validate and CheckProfileFitsMap,
/// PlanningMap::Graph and VerifyTrajectory do.
Status VerifyOnMap(const PlanningMap& map, const RobotProfile& profile,
                   const Trajectory& trajectory, const VerifierConfig& config = {},
                   const std::function<bool()>& should_stop = {});

/// Where Plan puts a start or goal requested at `requested`: SnapToSurface (same tolerance,
/// same failures) onto the nodes whose reference point keeps `min_obstacle_distance_m` [m]
/// from obstacles and where a robot at rest stands clearly on the node's ground, not halfway
/// between two grounds of its column (the verifier's rules: an end elsewhere could never be
/// verified; when every node within tolerance is refused, the error says so), with position_m
/// moved to exactly where the trajectory starts or ends there: the requested x, y at the
/// reference height above the ground when they lie in the snapped node's column and keep
/// that distance and ground too (the robot is where it says), else the node's reference point.
Expected<SnapResult> SnapEndpoint(
    const SurfaceGraph& graph, const Eigen::Vector3d& requested, double tolerance_m,
    ErrorCode off_ground_code,
    double min_obstacle_distance_m = VerifierConfig{}.min_obstacle_distance_m);

/// Legs of earlier plans, for a caller that plans one robot's route again with a few of its
/// stops changed (PlanAmongTraffic, adding stops to wait at): a leg from the same state to the
/// same state through the same points, among the same keep-out zones, is taken from here
/// instead of being planned again, as it would come out the same. The caller keeps one cache
/// per map version, profile and options; the zones are compared.
class LegCache {
 public:
  LegCache();
  ~LegCache();
  LegCache(LegCache&&) noexcept;
  LegCache& operator=(LegCache&&) noexcept;
  LegCache(const LegCache&) = delete;
  LegCache& operator=(const LegCache&) = delete;

  int hits() const;  ///< Legs taken from the cache so far.

  struct Entries;  ///< Defined where Plan is.
  Entries& entries() { return *entries_; }

 private:
  std::unique_ptr<Entries> entries_;
};

/// Plans one request on `map`, keeping the robot out of the map's and the request's keep-out
/// zones (searched around, pushed out of by the optimiser's J_k, checked by the verifier).
/// `should_stop` (may be empty) is polled throughout; returning true fails the plan with
/// kCancelled. Failures: kInvalidInput (non-finite state, malformed zone), kInvalidConfig,
/// kProfileMismatch, kStartOffGround / kGoalOffGround (with the nearest valid point),
/// kStartInKeepOut / kGoalInKeepOut (where the trajectory would start or end violates a zone;
/// the message names it), kGoalUnreachable (in milliseconds, from the components; or after the
/// search when keep-out zones cut the goal off, naming the zones in the way),
/// for a via the goal's codes blaming "via[i].position_m" (off the ground, in a zone) or
/// "via[i]" (unreachable from the point before it, or on that point's ground cell),
/// kDeadlineExceeded, kCancelled, kSearchBudgetExhausted, kOptimizationFailed (naming the
/// first violation).
/// With `legs` (may be null), legs are looked up there before they are planned, and kept
/// there once planned. A leg taken from it reports no time in PlanStats::timings.
Expected<PlanResult> Plan(const PlanningMap& map, const PlanRequest& request,
                          const std::function<bool()>& should_stop = {}, LegCache* legs = nullptr);

}  // namespace strata
