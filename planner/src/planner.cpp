#include "strata/planner.hpp"

#include "strata/common/seconds_since.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iterator>
#include <span>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/path_shortening.hpp"
#include "strata/planning/terrain_query.hpp"
#include "strata/planning/time_scaling.hpp"

namespace strata {
namespace {

using Clock = std::chrono::steady_clock;

// Time stretching (time_scaling.hpp): the largest factor tried, the fraction of each bound the
// stretched peaks are aimed at (the verifier samples between the peaks' samples), and the
// spacing of those samples [s].
constexpr double kMaxTimeStretch = 1.5;
constexpr double kStretchTarget = 0.995;
constexpr double kPeakSampleStepS = 0.01;

using common::SecondsSince;

// One should_stop for every stage: the caller's cancellation and the plan's own deadline,
// remembering which fired so the failure names the right reason.
class StopCondition {
 public:
  StopCondition(const std::function<bool()>& caller, Clock::time_point deadline)
      : caller_(caller), deadline_(deadline) {}

  bool operator()() {
    if (caller_ && caller_()) cancelled_ = true;
    if (!cancelled_ && Clock::now() >= deadline_) expired_ = true;
    return cancelled_ || expired_;
  }
  std::function<bool()> AsFunction() {
    return [this] { return (*this)(); };
  }
  // The error for a stage that stopped on our request.
  Error Reason(double budget_s, const char* stage) const {
    if (cancelled_)
      return Error{ErrorCode::kCancelled, std::string("plan cancelled during ") + stage};
    return Error{ErrorCode::kDeadlineExceeded,
                 fmt::format("the plan's time budget of {:.3f} s ran out during {}; allow more "
                             "time (options.time_budget_s or the call's deadline)",
                             budget_s, stage)};
  }
  bool stopped() const { return cancelled_ || expired_; }

 private:
  const std::function<bool()>& caller_;
  Clock::time_point deadline_;
  bool cancelled_ = false;
  bool expired_ = false;
};

// The dynamic bound whose peak in `stats` comes closest to the profile's bound.
void SetLimitingBound(const RobotProfile& profile, PlanStats* stats) {
  const std::pair<const char*, double> fractions[] = {
      {"horizontal_speed", stats->max_speed_horizontal_mps / profile.max_speed_horizontal_mps},
      {"vertical_speed", stats->max_speed_vertical_mps / profile.max_speed_vertical_mps},
      {"horizontal_acceleration",
       stats->max_accel_horizontal_mps2 / profile.max_accel_horizontal_mps2},
      {"vertical_acceleration", stats->max_accel_vertical_mps2 / profile.max_accel_vertical_mps2}};
  const auto* limiting =
      std::max_element(std::begin(fractions), std::end(fractions),
                       [](const auto& a, const auto& b) { return a.second < b.second; });
  stats->limiting_bound = limiting->first;
  stats->limiting_bound_fraction = limiting->second;
}

void FillStats(const Trajectory& trajectory, const VerificationReport& v,
               const RobotProfile& profile, PlanStats* stats) {
  stats->length_m = PathLength(trajectory);
  stats->duration_s = trajectory.TotalDuration();
  stats->mean_curvature_per_m = MeanCurvature(trajectory);
  stats->max_speed_horizontal_mps = v.max_speed_horizontal_mps;
  stats->max_speed_vertical_mps = v.max_speed_vertical_mps;
  stats->max_accel_horizontal_mps2 = v.max_accel_horizontal_mps2;
  stats->max_accel_vertical_mps2 = v.max_accel_vertical_mps2;
  stats->min_obstacle_distance_m = v.min_obstacle_distance_m;
  stats->max_ground_offset_m = v.max_ground_offset_m;
  stats->max_tilt_rad = v.max_tilt_rad;
  stats->min_body_height_m = v.min_body_height_m;
  stats->min_headroom_m = v.min_headroom_m;
  stats->pieces = static_cast<int>(trajectory.pieces.size());
  stats->verified_samples = v.samples;
  SetLimitingBound(profile, stats);
}

// kStartInKeepOut / kGoalInKeepOut: `what` ("start", "goal") at `p` violates `zone`.
Error InKeepOut(ErrorCode code, const char* what, const Eigen::Vector3d& p, const KeepOutZone& zone,
                const RobotProfile& profile, bool map_zone) {
  const double penetration = KeepOutPenetration(zone.prism, profile, p);
  return Error{
      code,
      fmt::format("{} {} m puts the robot inside {}: its footprint (radius {:.2f} m) "
                  "reaches {:.2f} m into the zone's polygon and its height range "
                  "overlaps the zone's [{:.2f}, {:.2f}] m; move the {} at least {:.2f} "
                  "m away from the zone{}",
                  what, internal::FormatPoint(p), zone.name, profile.footprint_radius_m,
                  penetration, zone.prism.z_min_m, zone.prism.z_max_m, what, penetration,
                  map_zone ? " (the map's zones change only with the map)" : " or drop the zone"),
      std::string(what) + ".position_m"};
}

// Optimises `problem` and verifies the result; when its only fault is being too fast
// somewhere (a speed or an acceleration a little over its bound), the same path stretched in
// time passes instead (time_scaling.hpp). Fails with the optimiser's error (kCancelled when
// `stop` fired) or the verifier's (kOptimizationFailed). Adds to the stats' timings,
// iterations and attempts; sets the figures and time_stretch of a trajectory it returns.
Expected<Trajectory> OptimizeAndVerify(const SurfaceGraph& graph, const RobotProfile& profile,
                                       std::span<const KeepOutZone> zones,
                                       const OptimizationProblem& problem,
                                       const OptimizerConfig& config,
                                       const VerifierConfig& verifier, StopCondition& stop,
                                       PlanStats* stats) {
  Clock::time_point stage = Clock::now();
  const TrajectoryCost cost(graph, config.weights, CostParams{profile, config.cost}, zones);
  Minco3 minco;
  Expected<OptimizationReport> report =
      OptimizeTrajectory(cost, problem, config, stop.AsFunction(), &minco);
  stats->timings.optimize_s += SecondsSince(stage);
  ++stats->optimizer_attempts;
  if (!report) return report.error();
  stats->optimizer_iterations += report->iterations;

  stage = Clock::now();
  Trajectory trajectory = Trajectory::FromMinco(minco);
  VerificationReport verification;
  Status verified = VerifyTrajectory(graph, profile, trajectory, verifier, &verification, zones);
  double stretch = 1;
  if (!verified) {
    const double k = RequiredTimeScale(SampleDynamicPeaks(trajectory, kPeakSampleStepS), profile,
                                       kStretchTarget);
    if (k > 1 && k <= kMaxTimeStretch) {
      Trajectory stretched = StretchTime(trajectory, k, problem.head_pva, problem.tail_pva);
      VerificationReport stretched_report;
      if (VerifyTrajectory(graph, profile, stretched, verifier, &stretched_report, zones)) {
        trajectory = std::move(stretched);
        verification = stretched_report;
        verified = Status::Ok();
        stretch = k;
      }
    }
  }
  stats->timings.verify_s += SecondsSince(stage);
  if (!verified) return verified.error();
  FillStats(trajectory, verification, profile, stats);
  stats->time_stretch = stretch;
  return trajectory;
}

// The fallback's trajectory (MakeFallbackProblem) as MINCO makes it, stretched in time
// until its speeds and accelerations are within the profile's bounds.
Trajectory SlowTrajectory(const OptimizationProblem& problem, const RobotProfile& profile) {
  Minco3 minco;
  minco.SetConditions(problem.head_pva, problem.tail_pva,
                      static_cast<int>(problem.initial_durations.size()));
  minco.SetParameters(problem.initial_waypoints, problem.initial_durations);
  Trajectory trajectory = Trajectory::FromMinco(minco);
  const double k =
      RequiredTimeScale(SampleDynamicPeaks(trajectory, kPeakSampleStepS), profile, kStretchTarget);
  if (k > 1) trajectory = StretchTime(trajectory, k, problem.head_pva, problem.tail_pva);
  return trajectory;
}

// A warm start's trajectory must be one this robot's plan could have returned.
Status ValidateWarmStart(const WarmStart& warm, const RobotProfile& profile) {
  const auto bad = [](const std::string& field, const std::string& what) {
    return Error{ErrorCode::kInvalidInput, field + " " + what, field};
  };
  const Trajectory& trajectory = warm.trajectory;
  const int dim = profile.active_height ? 4 : 3;
  if (trajectory.dimension != dim) {
    return bad(
        "warm_start.trajectory.dimension",
        fmt::format("is {}; this robot's trajectories have {} axes", trajectory.dimension, dim));
  }
  if (Status s = trajectory.ValidatePieces("warm_start.trajectory", kMaxWarmStartPieces); !s) {
    return s;
  }
  if (!std::isfinite(warm.elapsed_s)) return bad("warm_start.elapsed_s", "must be finite");
  return Status::Ok();
}

}  // namespace

std::vector<KeepOutZone> CollectKeepOut(const PlanningMap& map,
                                        std::span<const Prism> request_zones) {
  std::vector<KeepOutZone> zones;
  zones.reserve(map.keep_out().size() + request_zones.size());
  for (std::size_t i = 0; i < map.keep_out().size(); ++i) {
    zones.emplace_back(map.keep_out()[i], fmt::format("the map's keep-out zone {}", i));
  }
  for (std::size_t i = 0; i < request_zones.size(); ++i) {
    zones.emplace_back(request_zones[i], fmt::format("keep-out zone keep_out[{}]", i));
  }
  return zones;
}

Status VerifyOnMap(const PlanningMap& map, const RobotProfile& profile,
                   const Trajectory& trajectory, const VerifierConfig& config,
                   const std::function<bool()>& should_stop) {
  if (Status s = profile.Validate(); !s) return s;
  if (Status s = CheckProfileFitsMap(profile, map.model().config()); !s) return s;
  Expected<std::shared_ptr<const SurfaceGraph>> graph =
      map.Graph(profile.Traversability(), should_stop);
  if (!graph) return graph.error();
  VerificationReport report;
  return VerifyTrajectory(**graph, profile, trajectory, config, &report, CollectKeepOut(map, {}));
}

namespace {

// Whether the verifier sees a robot at rest with its reference point at `p` standing on
// `surface`, and still does a centimetre higher or lower. Not so halfway between two grounds
// of a column (a floor the assessment split in two): there the rounding of p picks either,
// and that the robot stays on one ground can never be shown between samples.
bool StandsOn(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
              const ColumnSurface& surface) {
  constexpr double kBandM = 0.01;
  for (const double dz : {-kBandM, 0.0, kBandM}) {
    GroundSample ground;
    if (!SampleGround(model, p + Eigen::Vector3d(0, 0, dz), reference_height_m, 0, &ground) ||
        ground.surface != &surface) {
      return false;
    }
  }
  return true;
}

}  // namespace

Expected<SnapResult> SnapEndpoint(const SurfaceGraph& graph, const Eigen::Vector3d& requested,
                                  double tolerance_m, ErrorCode off_ground_code,
                                  double min_obstacle_distance_m) {
  const double h_ref = graph.params().reference_height_m;
  // The reference point of a robot at rest on `node`'s ground at `xy`.
  const auto standing = [&](int node, const Eigen::Vector2d& xy) -> std::optional<Eigen::Vector3d> {
    const Eigen::Vector3d at(xy.x(), xy.y(), graph.position(node).z());
    GroundSample ground;
    if (!SampleGround(graph.model(), at, h_ref, 0, &ground)) return std::nullopt;
    const Eigen::Vector3d on_ground(xy.x(), xy.y(), ground.height_m + h_ref);
    if (!StandsOn(graph.model(), on_ground, h_ref, graph.surface(node))) return std::nullopt;
    return on_ground;
  };
  // Only where verification can pass: a trajectory's end whose reference point is closer to
  // an obstacle than the verifier allows, or where the robot's ground is ambiguous, could
  // never be returned.
  const auto clear = [&](int node) {
    return graph.clearance(node) >= min_obstacle_distance_m &&
           standing(node, graph.position(node).head<2>()).has_value();
  };
  const std::string refusal = fmt::format(
      "closer than {:.3f} m (verifier.min_obstacle_distance_m) to an obstacle, or "
      "halfway between two grounds of one column",
      min_obstacle_distance_m);
  Expected<SnapResult> snap =
      SnapToSurface(graph, requested, tolerance_m, off_ground_code, clear, refusal);
  if (!snap) return snap;
  // The requested x, y on the ground when they lie in the snapped node's column and keep the
  // same distance from obstacles; else the node's reference point.
  const Eigen::Vector3d candidate(requested.x(), requested.y(), snap->position_m.z());
  if (graph.grid().CellOf(candidate).head<2>() != graph.cell(snap->node).head<2>()) return snap;
  const std::optional<Eigen::Vector3d> on_ground = standing(snap->node, requested.head<2>());
  if (on_ground && graph.model().Distance(*on_ground) >= min_obstacle_distance_m) {
    snap->position_m = *on_ground;
  }
  return snap;
}

struct PlanningMap::GraphEntry {
  std::once_flag once;
  std::atomic<bool> built{false};  // Set (release) once graph or error is final.
  std::shared_ptr<const SurfaceGraph> graph;
  Error error{ErrorCode::kInvalidConfig, {}};
  std::list<TraversabilityParams>::iterator recency;  // In recency_; guarded by mutex_.

  // The graph's bytes once built, 0 before (or for a failed build).
  std::size_t Bytes() const {
    return built.load(std::memory_order_acquire) && graph != nullptr ? graph->MemoryBytes() : 0;
  }
};

PlanningMap::PlanningMap(std::shared_ptr<const TerrainModel> model, std::vector<Prism> keep_out,
                         std::size_t max_graph_bytes, std::shared_ptr<const GraphArchive> archive)
    : model_(std::move(model)),
      keep_out_(std::move(keep_out)),
      max_graph_bytes_(max_graph_bytes),
      archive_(std::move(archive)) {}

std::shared_ptr<const PlanningMap> PlanningMap::WithKeepOut(std::vector<Prism> keep_out) const {
  auto copy =
      std::make_shared<PlanningMap>(model_, std::move(keep_out), max_graph_bytes_, archive_);
  std::lock_guard lock(mutex_);
  // Oldest first, so that the copy's recency list keeps this one's order.
  for (auto it = recency_.rbegin(); it != recency_.rend(); ++it) {
    const GraphEntry& entry = *graphs_.at(*it);
    if (!entry.built.load(std::memory_order_acquire) || entry.graph == nullptr) continue;
    auto held = std::make_shared<GraphEntry>();
    std::call_once(held->once, [&] { held->graph = entry.graph; });
    held->built.store(true, std::memory_order_release);
    copy->recency_.push_front(*it);
    held->recency = copy->recency_.begin();
    copy->graphs_.emplace(*it, std::move(held));
  }
  return copy;
}

Expected<std::shared_ptr<const SurfaceGraph>> PlanningMap::Graph(
    const TraversabilityParams& params, const std::function<bool()>& should_stop) const {
  return GraphMadeBy(params, should_stop, Archived::kLookFirst,
                     [&](const std::function<bool()>& stop) {
                       return SurfaceGraph::Build(*model_, params, stop);
                     });
}

Expected<std::shared_ptr<const SurfaceGraph>> PlanningMap::GraphPatchedFrom(
    const PlanningMap& base, const CellBox& changed_columns, const TraversabilityParams& params,
    const std::function<bool()>& should_stop) const {
  const std::shared_ptr<const SurfaceGraph> from = base.BuiltGraph(params);
  if (from == nullptr) return Graph(params, should_stop);
  return GraphMadeBy(
      params, should_stop, Archived::kMakeFirst, [&](const std::function<bool()>& stop) {
        Expected<SurfaceGraph> patched = SurfaceGraph::Patch(*from, *model_, changed_columns, stop);
        // Another grid: nothing to patch from.
        if (!patched && patched.error().code == ErrorCode::kInvalidInput) {
          return SurfaceGraph::Build(*model_, params, stop);
        }
        return patched;
      });
}

std::size_t PlanningMap::MakeGraphsAhead(const PlanningMap& base, const CellBox* changed_columns,
                                         std::size_t max_graphs,
                                         const std::function<bool()>& should_stop) const {
  std::vector<TraversabilityParams> robots = base.BuiltGraphParams();
  if (robots.size() > max_graphs) robots.resize(max_graphs);
  for (const TraversabilityParams& params : robots) {
    if (should_stop && should_stop()) break;
    (void)(changed_columns != nullptr
               ? GraphPatchedFrom(base, *changed_columns, params, should_stop)
               : Graph(params, should_stop));
  }
  return robots.size();
}

std::shared_ptr<const SurfaceGraph> PlanningMap::BuiltGraph(
    const TraversabilityParams& params) const {
  std::lock_guard lock(mutex_);
  const auto it = graphs_.find(params);
  if (it == graphs_.end() || !it->second->built.load(std::memory_order_acquire)) return nullptr;
  return it->second->graph;
}

Expected<std::shared_ptr<const SurfaceGraph>> PlanningMap::GraphMadeBy(
    const TraversabilityParams& params, const std::function<bool()>& should_stop, Archived archived,
    const GraphMaker& make) const {
  while (true) {
    bool built_here = false;
    Expected<std::shared_ptr<const SurfaceGraph>> graph =
        GraphOnce(params, should_stop, archived, make, &built_here);
    // Another caller's build was stopped (its caller gave up, not this one): build it here.
    if (!graph && graph.error().code == ErrorCode::kCancelled && !built_here &&
        !(should_stop && should_stop())) {
      continue;
    }
    return graph;
  }
}

Expected<std::shared_ptr<const SurfaceGraph>> PlanningMap::GraphOnce(
    const TraversabilityParams& params, const std::function<bool()>& should_stop, Archived archived,
    const GraphMaker& make, bool* built_here) const {
  if (Status s = params.Validate(); !s) return std::move(s).error();
  std::shared_ptr<GraphEntry> entry;
  {
    std::lock_guard lock(mutex_);
    std::shared_ptr<GraphEntry>& slot = graphs_[params];
    if (slot == nullptr) {
      slot = std::make_shared<GraphEntry>();
      recency_.push_front(params);
      slot->recency = recency_.begin();
    } else {
      recency_.splice(recency_.begin(), recency_, slot->recency);
    }
    entry = slot;
  }
  std::call_once(entry->once, [&] {
    *built_here = true;
    if (archive_ != nullptr && archived == Archived::kLookFirst) {
      std::optional<SurfaceGraph> kept = archive_->Find(*model_, params);
      if (kept && kept->params() == params) {
        entry->graph = std::make_shared<const SurfaceGraph>(std::move(*kept));
        entry->built.store(true, std::memory_order_release);
        return;
      }
    }
    Expected<SurfaceGraph> graph = make(should_stop);
    if (graph) {
      entry->graph = std::make_shared<const SurfaceGraph>(std::move(graph).value());
      if (archive_ != nullptr && (archived == Archived::kLookFirst || !archive_->Holds(params))) {
        archive_->Keep(model_, entry->graph);
      }
    } else {
      entry->error = graph.error();
    }
    entry->built.store(true, std::memory_order_release);
  });
  std::shared_ptr<const SurfaceGraph> graph = entry->graph;  // Held: never dropped below.
  std::lock_guard lock(mutex_);
  if (graph == nullptr) {
    if (const auto it = graphs_.find(params); it != graphs_.end() && it->second == entry) {
      recency_.erase(entry->recency);
      graphs_.erase(it);
    }
    return entry->error;
  }
  DropGraphsLocked();
  return graph;
}

void PlanningMap::DropGraphsLocked() const {
  if (max_graph_bytes_ == 0) return;
  std::size_t bytes = 0;
  for (const auto& [key, entry] : graphs_) bytes += entry->Bytes();
  for (auto it = recency_.end(); bytes > max_graph_bytes_ && it != recency_.begin();) {
    --it;
    if (it == recency_.begin()) break;  // The one just asked for.
    const auto slot = graphs_.find(*it);
    const GraphEntry& entry = *slot->second;
    // Built, and held by this cache alone: no plan runs on it, dropping it frees it.
    if (entry.built.load(std::memory_order_acquire) && entry.graph.use_count() == 1) {
      bytes -= entry.Bytes();
      graphs_.erase(slot);
      it = recency_.erase(it);
    }
  }
}

std::size_t PlanningMap::MemoryBytes() const {
  std::size_t bytes = model_->MemoryBytes();
  std::lock_guard lock(mutex_);
  for (const auto& [key, entry] : graphs_) bytes += entry->Bytes();
  return bytes;
}

std::size_t PlanningMap::MemoryBytesBeyond(const PlanningMap* made_from) const {
  if (made_from == nullptr) return MemoryBytes();
  if (made_from == this) return 0;
  const PlanningMap& other = *made_from;
  std::size_t bytes = model_->MemoryBytesBeyond(*other.model_);
  std::scoped_lock lock(mutex_, other.mutex_);
  // A graph is read once built (its entry's flag), as Bytes reads it.
  const auto built = [](const GraphEntry& entry) {
    return entry.built.load(std::memory_order_acquire) ? entry.graph : nullptr;
  };
  for (const auto& [key, entry] : graphs_) {
    const auto theirs = other.graphs_.find(key);
    const bool shared = built(*entry) != nullptr && theirs != other.graphs_.end() &&
                        built(*theirs->second) == built(*entry);
    if (!shared) bytes += entry->Bytes();
  }
  return bytes;
}

std::size_t PlanningMap::GraphCount() const {
  std::lock_guard lock(mutex_);
  return graphs_.size();
}

std::vector<TraversabilityParams> PlanningMap::BuiltGraphParams() const {
  std::lock_guard lock(mutex_);
  std::vector<TraversabilityParams> params;
  for (const TraversabilityParams& key : recency_) {
    const GraphEntry& entry = *graphs_.at(key);
    if (entry.built.load(std::memory_order_acquire) && entry.graph != nullptr) {
      params.push_back(key);
    }
  }
  return params;
}

Status PlanOptions::Validate(std::string_view path) const {
  using internal::FieldPath;
  if (!(std::isfinite(time_budget_s) && time_budget_s > 0)) {
    return internal::OutOfRange(FieldPath(path, "time_budget_s"), time_budget_s, "> 0 and finite");
  }
  if (!(std::isfinite(snap_tolerance_m) && snap_tolerance_m >= 0)) {
    return internal::OutOfRange(FieldPath(path, "snap_tolerance_m"), snap_tolerance_m,
                                ">= 0 and finite");
  }
  if (max_attempts < 1 || max_attempts > 10) {
    return internal::OutOfRange(FieldPath(path, "max_attempts"), max_attempts, "in [1, 10]");
  }
  if (Status s = search.Validate(FieldPath(path, "search")); !s) return s;
  if (Status s = optimizer.Validate(FieldPath(path, "optimizer")); !s) return s;
  return verifier.Validate(FieldPath(path, "verifier"));
}

Status PlanRequest::Validate() const {
  if (Status s = start.Validate("start"); !s) return s;
  if (Status s = goal.Validate("goal"); !s) return s;
  if (Status s = profile.Validate("profile"); !s) return s;
  if (Status s = options.Validate("options"); !s) return s;
  if (keep_out.size() > static_cast<std::size_t>(kMaxRequestKeepOutZones)) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("keep_out has {} zones, more than the {} one request may carry: "
                             "merge neighbouring zones, or make lasting ones part of the map",
                             keep_out.size(), kMaxRequestKeepOutZones),
                 "keep_out"};
  }
  if (warm_start) {
    if (Status s = ValidateWarmStart(*warm_start, profile); !s) return s;
  }
  if (via.size() > static_cast<std::size_t>(kMaxVias)) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("via has {} points, more than the {} one request may carry: split "
                             "the route into several plans",
                             via.size(), kMaxVias),
                 "via"};
  }
  for (std::size_t i = 0; i < via.size(); ++i) {
    RobotState at;  // Checked as a state's position is: finite, within the coordinate bound.
    at.position_m = via[i].position_m;
    if (Status s = at.Validate("via[" + std::to_string(i) + "]"); !s) return s;
  }
  for (std::size_t i = 0; i < keep_out.size(); ++i) {
    const std::string path = "keep_out[" + std::to_string(i) + "]";
    if (Status s = keep_out[i].Validate(path); !s) return s;
    // A robot overlaps a zone only by more than zero height (keep_out.hpp).
    if (!(keep_out[i].z_max_m > keep_out[i].z_min_m)) {
      const std::string field = internal::FieldPath(path, "z_max_m");
      std::string message = field;
      message += " must be above ";
      message += internal::FieldPath(path, "z_min_m");
      message += ": a keep-out zone of no height blocks nothing";
      return Error{ErrorCode::kInvalidInput, std::move(message), field};
    }
  }
  return Status::Ok();
}

namespace {

// A point a leg passes through or ends at: where it snapped, and its name in messages.
struct RoutePoint {
  SnapResult snap;
  std::string name;  // "start", "goal", "via[2]".
};

// What one plan shares with each of its legs.
struct LegContext {
  const SurfaceGraph& graph;
  const RobotProfile& profile;
  const PlanOptions& options;
  std::span<const KeepOutZone> zones;
  StopCondition& stop;
};

// One leg of a route: from rest (or the request's start) to rest (or the request's goal).
struct Leg {
  Trajectory trajectory;
  PathResult path;
  std::vector<double> via_times_s;  // Of the flow-through vias inside, from the leg's start.
  PlanStats stats;
};

}  // namespace

struct LegCache::Entries {
  // Legs kept at most; the oldest goes first (a fleet plan makes a handful).
  static constexpr std::size_t kMaxLegs = 32;
  struct Entry {
    RobotState head;
    RobotState tail;
    std::vector<Eigen::Vector3d> points_m;  // Where the leg's points snapped, in order.
    std::vector<Prism> zones;               // Every zone the leg kept out of.
    Leg leg;
  };
  std::vector<Entry> legs;
  int hits = 0;
};

LegCache::LegCache() : entries_(std::make_unique<Entries>()) {}
LegCache::~LegCache() = default;
LegCache::LegCache(LegCache&&) noexcept = default;
LegCache& LegCache::operator=(LegCache&&) noexcept = default;
int LegCache::hits() const { return entries_->hits; }

namespace {

bool SameState(const RobotState& a, const RobotState& b) {
  return a.position_m == b.position_m && a.velocity_mps == b.velocity_mps &&
         a.acceleration_mps2 == b.acceleration_mps2;
}

bool SameZones(std::span<const Prism> kept, std::span<const KeepOutZone> zones) {
  return std::equal(kept.begin(), kept.end(), zones.begin(), zones.end(),
                    [](const Prism& a, const KeepOutZone& b) {
                      return a.polygon_m == b.prism.polygon_m && a.z_min_m == b.prism.z_min_m &&
                             a.z_max_m == b.prism.z_max_m;
                    });
}

// Appends `part` to `joined`, the point where they meet once.
void AppendPath(const PathResult& part, PathResult* joined) {
  const std::size_t skip = joined->points_m.empty() ? 0 : 1;
  joined->points_m.insert(joined->points_m.end(), part.points_m.begin() + skip,
                          part.points_m.end());
  joined->nodes.insert(joined->nodes.end(), part.nodes.begin() + skip, part.nodes.end());
  joined->length_m += part.length_m;
  joined->cost += part.cost;
  joined->expansions += part.expansions;
}

// The time at which `trajectory` reaches the end of waypoint column `column` (piece `column`).
double TimeAtWaypoint(const Trajectory& trajectory, int column) {
  double t = 0;
  for (int i = 0; i <= column; ++i) t += trajectory.pieces[static_cast<std::size_t>(i)].duration_s;
  return t;
}

// Adds a later leg's figures to the whole route's (the first leg's are copied as they are).
void MergeLegStats(const PlanStats& leg, const RobotProfile& profile, PlanStats* total) {
  total->length_m += leg.length_m;
  total->duration_s += leg.duration_s;
  total->max_speed_horizontal_mps =
      std::max(total->max_speed_horizontal_mps, leg.max_speed_horizontal_mps);
  total->max_speed_vertical_mps =
      std::max(total->max_speed_vertical_mps, leg.max_speed_vertical_mps);
  total->max_accel_horizontal_mps2 =
      std::max(total->max_accel_horizontal_mps2, leg.max_accel_horizontal_mps2);
  total->max_accel_vertical_mps2 =
      std::max(total->max_accel_vertical_mps2, leg.max_accel_vertical_mps2);
  total->min_obstacle_distance_m =
      std::min(total->min_obstacle_distance_m, leg.min_obstacle_distance_m);
  total->max_ground_offset_m = std::max(total->max_ground_offset_m, leg.max_ground_offset_m);
  total->max_tilt_rad = std::max(total->max_tilt_rad, leg.max_tilt_rad);
  total->min_body_height_m = std::min(total->min_body_height_m, leg.min_body_height_m);
  total->min_headroom_m = std::min(total->min_headroom_m, leg.min_headroom_m);
  total->pieces += leg.pieces;
  total->search_expansions += leg.search_expansions;
  total->optimizer_iterations += leg.optimizer_iterations;
  total->optimizer_attempts += leg.optimizer_attempts;
  total->verified_samples += leg.verified_samples;
  total->time_stretch = std::max(total->time_stretch, leg.time_stretch);
  if (leg.fallback && !total->fallback) total->fallback_reason = leg.fallback_reason;
  total->fallback = total->fallback || leg.fallback;
  SetLimitingBound(profile, total);
  total->timings.graph_s += leg.timings.graph_s;
  total->timings.snap_s += leg.timings.snap_s;
  total->timings.search_s += leg.timings.search_s;
  total->timings.optimize_s += leg.timings.optimize_s;
  total->timings.verify_s += leg.timings.verify_s;
}

// A leg's paths: the A* paths between its consecutive points, shortened and joined, and as
// found (the fallback's second way), with where the flow-through vias lie in each.
struct LegPaths {
  PathResult shortened;
  std::vector<std::size_t> shortened_vias;
  PathResult searched;
  std::vector<std::size_t> searched_vias;
};

// Searches each stretch of the leg between consecutive `points`; the vias are where they join.
Expected<LegPaths> SearchLeg(const LegContext& ctx, std::span<const RoutePoint> points,
                             PlanStats* stats) {
  const SurfaceGraph& graph = ctx.graph;
  const std::span<const KeepOutZone> zones = ctx.zones;
  std::vector<int> blocked_nodes(zones.size(), 0);  // Per zone, nodes the search left out.
  std::function<bool(int)> blocked;
  if (!zones.empty()) {
    blocked = [&](int node) {
      const int zone = FirstViolatedKeepOut(zones, ctx.profile, graph.position(node));
      if (zone < 0) return false;
      ++blocked_nodes[zone];
      return true;
    };
  }
  const Clock::time_point stage = Clock::now();
  LegPaths paths;
  for (std::size_t k = 0; k + 1 < points.size(); ++k) {
    const RoutePoint& from = points[k];
    const RoutePoint& to = points[k + 1];
    // The search runs on the plan's own budget (through stop), the only one a caller sets.
    SearchStats search_stats;
    Expected<PathResult> path = SearchPath(graph, from.snap.node, to.snap.node, ctx.options.search,
                                           ctx.stop.AsFunction(), &search_stats, blocked);
    stats->search_expansions += search_stats.expansions;
    if (!path) {
      stats->timings.search_s += SecondsSince(stage);
      if (ctx.stop.stopped()) return ctx.stop.Reason(ctx.options.time_budget_s, "the path search");
      Error error = std::move(path).error();
      std::string in_the_way;  // The zones the search met, by name.
      for (std::size_t i = 0; i < zones.size(); ++i) {
        if (blocked_nodes[i] == 0) continue;
        in_the_way += (in_the_way.empty() ? "" : ", ") + zones[i].name;
      }
      if (!in_the_way.empty() && error.code == ErrorCode::kNoPath) {
        // The components connect the two points; only the zones separate them.
        return Error{ErrorCode::kGoalUnreachable,
                     to.name + " " + internal::FormatPoint(to.snap.position_m) +
                         " m cannot be reached from " + from.name + " " +
                         internal::FormatPoint(from.snap.position_m) +
                         " m without entering the keep-out zones in the way (" + in_the_way +
                         "): every way round is closed; move or shrink a zone, or choose another " +
                         to.name,
                     to.name == "goal" ? std::string() : to.name,
                     {{"zones_in_the_way", in_the_way}}};
      }
      if (!in_the_way.empty())
        error.message += "; the search stepped around keep-out zones " + in_the_way;
      return error;
    }
    // Straightened inside the traversable corridor: the optimiser starts near the smooth
    // answer instead of the grid's zigzag.
    AppendPath(ShortenPath(graph, *path, ctx.options.search, {}, blocked), &paths.shortened);
    AppendPath(*path, &paths.searched);
    if (k + 2 < points.size()) {
      paths.shortened_vias.push_back(paths.shortened.points_m.size() - 1);
      paths.searched_vias.push_back(paths.searched.points_m.size() - 1);
    }
  }
  stats->timings.search_s += SecondsSince(stage);
  return paths;
}

// The points a leg's trajectory starts from: a path's, its ends the states' and its vias the
// snapped ones.
std::vector<Eigen::Vector3d> WaypointsOf(std::vector<Eigen::Vector3d> path_points,
                                         std::span<const std::size_t> vias,
                                         std::span<const RoutePoint> points, const RobotState& head,
                                         const RobotState& tail) {
  path_points.front() = head.position_m;
  path_points.back() = tail.position_m;
  for (std::size_t v = 0; v < vias.size(); ++v) {
    path_points[vias[v]] = points[v + 1].snap.position_m;
  }
  if (path_points.size() < 2) path_points.push_back(tail.position_m);
  return path_points;
}

// Stiffer penalties for the next attempt (PlanOptions::max_attempts documents them). Not S',
// the smooth safety field: stiffening it, which every retry used to, pushed the trajectory
// harder against the rim in passages whose ground is rough on both sides.
void StiffenForRetry(OptimizerConfig* config) {
  config->cost.distance_stiffness *= 4;
  config->weights.edge *= 4;
  config->weights.ground *= 4;
  config->cost.ground_band_m *= 0.25;
  config->weights.feasibility *= 4;
  config->weights.keep_out *= 4;
  config->piece_length_m *= 0.7;
  config->cost.limit_margin *= 0.95;
  config->initial_speed_fraction *= 0.75;
}

// The leg's trajectory and when it passes its vias.
Leg FinishLeg(Leg leg, Trajectory trajectory, const OptimizationProblem& problem) {
  for (const int column : problem.pinned_waypoints) {
    leg.via_times_s.push_back(TimeAtWaypoint(trajectory, column));
  }
  leg.trajectory = std::move(trajectory);
  return leg;
}

// The last resort: the path itself, slowly, marked as such for the dispatcher. First the
// shortened path, then the searched one as found: its steps go from column centre to column
// centre, where the shortened path's lines may cross a column whose ground the interpolation
// between columns misjudges (a ramp's edge).
Expected<Leg> FallbackLeg(const LegContext& ctx, std::span<const RoutePoint> points,
                          const RobotState& head, const RobotState& tail, LegPaths paths,
                          const std::vector<Eigen::Vector3d>& waypoints,
                          const OptimizerConfig& config, Error last_failure, Leg leg) {
  const PlanOptions& options = ctx.options;
  PlanStats& stats = leg.stats;
  Clock::time_point stage = Clock::now();
  const TrajectoryCost cost(ctx.graph, config.weights, CostParams{ctx.profile, config.cost},
                            ctx.zones);
  for (const bool shortened : {true, false}) {
    const std::span<const std::size_t> vias =
        shortened ? paths.shortened_vias : paths.searched_vias;
    const OptimizationProblem fallback = MakeFallbackProblem(
        cost,
        shortened ? waypoints : WaypointsOf(paths.searched.points_m, vias, points, head, tail),
        head, tail, options.verifier.min_obstacle_distance_m, vias);
    Trajectory slow = SlowTrajectory(fallback, ctx.profile);
    VerificationReport verification;
    const Status verified =
        VerifyTrajectory(ctx.graph, ctx.profile, slow, options.verifier, &verification, ctx.zones);
    stats.timings.verify_s += SecondsSince(stage);
    stage = Clock::now();
    if (verified) {
      FillStats(slow, verification, ctx.profile, &stats);
      stats.fallback = true;
      stats.fallback_reason = last_failure.message;
      if (!shortened) leg.path = std::move(paths.searched);  // The path the trajectory follows.
      return FinishLeg(std::move(leg), std::move(slow), fallback);
    }
    if (ctx.stop()) return ctx.stop.Reason(options.time_budget_s, "the slow fallback");
  }
  last_failure.message +=
      fmt::format(" (after {} attempts and the slow fallback)", options.max_attempts);
  return last_failure;
}

// Searches, optimises and verifies one leg through `points` (its first the leg's start, its
// last the leg's end, flow-through vias between): the A* paths between consecutive points,
// shortened and joined, initialise a trajectory that passes exactly through each via
// (pinned waypoints); retries and the slow fallback as Plan documents.
Expected<Leg> PlanLeg(const LegContext& ctx, std::span<const RoutePoint> points,
                      const RobotState& head, const RobotState& tail) {
  const PlanOptions& options = ctx.options;
  Leg leg;
  Expected<LegPaths> paths = SearchLeg(ctx, points, &leg.stats);
  if (!paths) return std::move(paths).error();
  leg.path = paths->shortened;
  const std::vector<Eigen::Vector3d> waypoints =
      WaypointsOf(leg.path.points_m, paths->shortened_vias, points, head, tail);
  // Optimise and verify; a failed verification retries with stiffer penalties.
  OptimizerConfig config = options.optimizer;
  Error last_failure{ErrorCode::kOptimizationFailed, "no optimisation attempt ran"};
  for (int k = 0; k < options.max_attempts; ++k) {
    const TrajectoryCost cost(ctx.graph, config.weights, CostParams{ctx.profile, config.cost},
                              ctx.zones);
    const OptimizationProblem problem =
        MakeInitialProblem(cost, waypoints, head, tail, config, paths->shortened_vias);
    Expected<Trajectory> trajectory = OptimizeAndVerify(
        ctx.graph, ctx.profile, ctx.zones, problem, config, options.verifier, ctx.stop, &leg.stats);
    if (trajectory) return FinishLeg(std::move(leg), std::move(trajectory).value(), problem);
    if (ctx.stop.stopped()) {
      return ctx.stop.Reason(options.time_budget_s, "trajectory optimisation");
    }
    if (trajectory.error().code != ErrorCode::kOptimizationFailed) return trajectory.error();
    last_failure = trajectory.error();
    if (ctx.stop()) return ctx.stop.Reason(options.time_budget_s, "trajectory verification");
    StiffenForRetry(&config);
  }
  return FallbackLeg(ctx, points, head, tail, std::move(paths).value(), waypoints, config,
                     std::move(last_failure), std::move(leg));
}

// PlanLeg, through `cache` when there is one: a leg it holds is taken (its timings zeroed, as
// no time went into it), one planned is kept.
Expected<Leg> PlanLegThrough(LegCache* cache, const LegContext& ctx,
                             std::span<const RoutePoint> points, const RobotState& head,
                             const RobotState& tail) {
  if (cache == nullptr) return PlanLeg(ctx, points, head, tail);
  LegCache::Entries& entries = cache->entries();
  const auto same_points = [&](const std::vector<Eigen::Vector3d>& kept) {
    return std::equal(
        kept.begin(), kept.end(), points.begin(), points.end(),
        [](const Eigen::Vector3d& a, const RoutePoint& b) { return a == b.snap.position_m; });
  };
  for (const LegCache::Entries::Entry& entry : entries.legs) {
    if (SameState(entry.head, head) && SameState(entry.tail, tail) && same_points(entry.points_m) &&
        SameZones(entry.zones, ctx.zones)) {
      ++entries.hits;
      Leg leg = entry.leg;
      leg.stats.timings = {};
      return leg;
    }
  }
  Expected<Leg> leg = PlanLeg(ctx, points, head, tail);
  if (!leg) return leg;
  if (entries.legs.size() >= LegCache::Entries::kMaxLegs) entries.legs.erase(entries.legs.begin());
  LegCache::Entries::Entry entry{head, tail, {}, {}, leg.value()};
  for (const RoutePoint& point : points) entry.points_m.push_back(point.snap.position_m);
  for (const KeepOutZone& zone : ctx.zones) entry.zones.push_back(zone.prism);
  entries.legs.push_back(std::move(entry));
  return leg;
}

// At rest at `p`: where a leg ends at a stop and the next begins.
RobotState AtRest(const Eigen::Vector3d& p) {
  RobotState state;
  state.position_m = p;
  return state;
}

// Off the ground, the position is what the caller must change.
Error Blame(Error error, const std::string& field) {
  error.field = field;
  return error;
}

// The route's points in order (start, the vias, goal), snapped onto `graph`; the snaps go
// into `result` too.
Expected<std::vector<RoutePoint>> SnapRoute(const SurfaceGraph& graph, const PlanRequest& request,
                                            PlanResult* result) {
  const PlanOptions& options = request.options;
  const double min_distance = options.verifier.min_obstacle_distance_m;
  Expected<SnapResult> start =
      SnapEndpoint(graph, request.start.position_m, options.snap_tolerance_m,
                   ErrorCode::kStartOffGround, min_distance);
  if (!start) return Blame(std::move(start).error(), "start.position_m");
  Expected<SnapResult> goal = SnapEndpoint(graph, request.goal.position_m, options.snap_tolerance_m,
                                           ErrorCode::kGoalOffGround, min_distance);
  if (!goal) return Blame(std::move(goal).error(), "goal.position_m");
  result->start = *start;
  result->goal = *goal;
  std::vector<RoutePoint> route = {{*start, "start"}};
  for (std::size_t i = 0; i < request.via.size(); ++i) {
    const std::string name = "via[" + std::to_string(i) + "]";
    Expected<SnapResult> via =
        SnapEndpoint(graph, request.via[i].position_m, options.snap_tolerance_m,
                     ErrorCode::kGoalOffGround, min_distance);
    if (!via) {
      Error error = std::move(via).error();
      if (error.message.starts_with("goal ")) error.message.replace(0, 4, name);
      return Blame(std::move(error), name + ".position_m");
    }
    result->via.push_back(*via);
    route.push_back({*via, name});
  }
  route.push_back({*goal, "goal"});
  return route;
}

// What makes a route impossible before any search: an end (or a via) inside a keep-out zone
// (the search steps around the zones, the graph stays as it is, shared by every request), a
// via (or the goal after one) in another connected component than the point before it
// (without vias the search says so for the goal), two consecutive points on one node (a leg
// of no length).
Status CheckRoute(const PlanningMap& map, const SurfaceGraph& graph, const PlanRequest& request,
                  std::span<const RoutePoint> route, std::span<const KeepOutZone> zones) {
  const RobotProfile& profile = request.profile;
  for (const RoutePoint& point : route) {
    const Eigen::Vector3d& p = point.snap.position_m;
    if (const int zone = FirstViolatedKeepOut(zones, profile, p); zone >= 0) {
      return InKeepOut(
          point.name == "start" ? ErrorCode::kStartInKeepOut : ErrorCode::kGoalInKeepOut,
          point.name.c_str(), p, zones[zone], profile,
          static_cast<std::size_t>(zone) < map.keep_out().size());
    }
  }
  for (std::size_t i = 1; i < route.size() && !request.via.empty(); ++i) {
    const RoutePoint& from = route[i - 1];
    const RoutePoint& to = route[i];
    if (graph.component(from.snap.node) == graph.component(to.snap.node)) continue;
    // The search refuses without expanding, with the components' labels and sizes.
    Error error =
        SearchPath(graph, from.snap.node, to.snap.node, request.options.search, {}).error();
    error.message = to.name + " " + internal::FormatPoint(to.snap.position_m) +
                    " m is not connected to " + from.name + " " +
                    internal::FormatPoint(from.snap.position_m) +
                    " m over traversable ground (they lie in different connected components): "
                    "move " +
                    to.name + " or drop it";
    if (i + 1 < route.size()) error.field = to.name;
    return error;
  }
  for (std::size_t i = 1; i < route.size(); ++i) {
    if (request.via.empty() || route[i - 1].snap.node != route[i].snap.node) continue;
    const RoutePoint& named = i + 1 < route.size() ? route[i] : route[i - 1];
    return Error{ErrorCode::kInvalidInput,
                 route[i].name + " " + internal::FormatPoint(route[i].snap.position_m) +
                     " m snaps to the same ground cell as " + route[i - 1].name + " " +
                     internal::FormatPoint(route[i - 1].snap.position_m) + " m: drop " +
                     named.name + " or move it",
                 named.name};
  }
  return Status::Ok();
}

// A replan along the trajectory the robot follows starts from its remainder, with no search:
// true when that verified (the result is complete). A warm start that does not fit, or fails
// verification, leaves the plan to be made from scratch, its timings and attempts counted.
Expected<bool> TryWarmStart(const LegContext& ctx, const WarmStart& warm_start,
                            const RobotState& head, const RobotState& tail, PlanResult* result) {
  const OptimizerConfig& config = ctx.options.optimizer;
  PlanStats& stats = result->stats;
  const TrajectoryCost cost(ctx.graph, config.weights, CostParams{ctx.profile, config.cost},
                            ctx.zones);
  Expected<OptimizationProblem> warm = MakeWarmProblem(cost, warm_start, head, tail);
  if (!warm) return false;
  PlanStats warm_stats = stats;
  Expected<Trajectory> trajectory =
      OptimizeAndVerify(ctx.graph, ctx.profile, ctx.zones, *warm, config, ctx.options.verifier,
                        ctx.stop, &warm_stats);
  if (trajectory) {
    result->trajectory = std::move(trajectory).value();
    stats = warm_stats;
    stats.warm_started = true;
    return true;
  }
  if (ctx.stop.stopped()) {
    return ctx.stop.Reason(ctx.options.time_budget_s, "trajectory optimisation");
  }
  if (trajectory.error().code != ErrorCode::kOptimizationFailed) return trajectory.error();
  // Its timings and attempts count; its figures were not kept.
  stats.timings = warm_stats.timings;
  stats.optimizer_attempts = warm_stats.optimizer_attempts;
  stats.optimizer_iterations = warm_stats.optimizer_iterations;
  return false;
}

// Adds a later leg's pieces and path to the route's.
void AppendLeg(Leg leg, PlanResult* result) {
  result->trajectory.pieces.insert(result->trajectory.pieces.end(), leg.trajectory.pieces.begin(),
                                   leg.trajectory.pieces.end());
  PathResult& path = result->path;
  path.points_m.insert(path.points_m.end(), leg.path.points_m.begin() + 1, leg.path.points_m.end());
  path.nodes.insert(path.nodes.end(), leg.path.nodes.begin() + 1, leg.path.nodes.end());
  path.length_m += leg.path.length_m;
  path.cost += leg.path.cost;
  path.expansions += leg.path.expansions;
}

// Plans the route leg by leg: legs end at the stops, each planned from rest to rest, and their
// pieces are joined.
Status PlanLegs(const LegContext& ctx, const PlanRequest& request,
                std::span<const RoutePoint> route, const RobotState& head, const RobotState& tail,
                LegCache* cache, PlanResult* result) {
  PlanStats& stats = result->stats;
  std::size_t leg_begin = 0;
  for (std::size_t i = 1; i < route.size(); ++i) {
    const bool last = i + 1 == route.size();
    if (!last && !request.via[i - 1].stop) continue;
    const RobotState leg_head = leg_begin == 0 ? head : AtRest(route[leg_begin].snap.position_m);
    const RobotState leg_tail = last ? tail : AtRest(route[i].snap.position_m);
    Expected<Leg> leg =
        PlanLegThrough(cache, ctx, route.subspan(leg_begin, i - leg_begin + 1), leg_head, leg_tail);
    if (!leg) return std::move(leg).error();
    const double leg_start_s = result->trajectory.TotalDuration();
    for (const double t : leg->via_times_s) result->via_times_s.push_back(leg_start_s + t);
    if (leg_begin == 0) {
      // The snap's timing, and a warm start's that did not pass, count too.
      const PlanStats before = stats;
      stats = leg->stats;
      stats.timings.graph_s += before.timings.graph_s;
      stats.timings.snap_s += before.timings.snap_s;
      stats.timings.optimize_s += before.timings.optimize_s;
      stats.timings.verify_s += before.timings.verify_s;
      stats.optimizer_attempts += before.optimizer_attempts;
      stats.optimizer_iterations += before.optimizer_iterations;
      result->trajectory = std::move(leg->trajectory);
      result->path = std::move(leg->path);
    } else {
      MergeLegStats(leg->stats, request.profile, &stats);
      AppendLeg(std::move(leg).value(), result);
    }
    if (!last) result->via_times_s.push_back(result->trajectory.TotalDuration());
    leg_begin = i;
  }
  return Status::Ok();
}

}  // namespace

Expected<PlanResult> Plan(const PlanningMap& map, const PlanRequest& request,
                          const std::function<bool()>& should_stop, LegCache* legs) {
  const Clock::time_point start_time = Clock::now();
  const PlanOptions& options = request.options;
  const RobotProfile& profile = request.profile;
  if (Status s = request.Validate(); !s) return std::move(s).error();
  if (Status s = CheckProfileFitsMap(profile, map.model().config()); !s) return s.error();
  const auto deadline = start_time + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options.time_budget_s));
  StopCondition stop(should_stop, deadline);
  PlanResult result;
  PlanStats& stats = result.stats;

  // Snap the route's points onto the robot's graph.
  const Clock::time_point stage = Clock::now();
  Expected<std::shared_ptr<const SurfaceGraph>> graph_or =
      map.Graph(profile.Traversability(), stop.AsFunction());
  if (!graph_or) {
    if (stop.stopped()) return stop.Reason(options.time_budget_s, "building the surface graph");
    return graph_or.error();
  }
  const SurfaceGraph& graph = **graph_or;
  stats.timings.graph_s = SecondsSince(stage);
  const Clock::time_point snapping = Clock::now();
  Expected<std::vector<RoutePoint>> route = SnapRoute(graph, request, &result);
  if (!route) return std::move(route).error();
  RobotState head = request.start, tail = request.goal;
  head.position_m = result.start.position_m;
  tail.position_m = result.goal.position_m;
  stats.timings.snap_s = SecondsSince(snapping);

  // Keep-out zones: the trajectory's ends (and vias) must lie outside every zone; the search
  // steps around them, the optimiser's J_k keeps the trajectory out with a margin and the
  // verifier checks every sample.
  const std::vector<KeepOutZone> zones = CollectKeepOut(map, request.keep_out);
  if (Status possible = CheckRoute(map, graph, request, *route, zones); !possible) {
    return std::move(possible).error();
  }
  const LegContext context{graph, profile, options, zones, stop};
  // Not for a route through vias: the remainder of a warm start would not be pinned at them.
  if (request.warm_start && request.via.empty()) {
    Expected<bool> warm = TryWarmStart(context, *request.warm_start, head, tail, &result);
    if (!warm) return std::move(warm).error();
    if (*warm) {
      stats.timings.total_s = SecondsSince(start_time);
      return result;
    }
  }
  if (Status planned = PlanLegs(context, request, *route, head, tail, legs, &result); !planned) {
    return std::move(planned).error();
  }
  if (!request.via.empty()) stats.mean_curvature_per_m = MeanCurvature(result.trajectory);
  stats.timings.total_s = SecondsSince(start_time);
  return result;
}

}  // namespace strata
