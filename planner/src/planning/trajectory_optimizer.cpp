#include "strata/planning/trajectory_optimizer.hpp"

#include <LBFGS.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numeric>
#include <span>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "planning/trajectory_optimizer_internal.hpp"
#include "strata/planning/terrain_query.hpp"

namespace strata {
namespace {

// L-BFGS runs per optimisation at most (see the restart loop).
constexpr int kMaxRestarts = 8;

// A polyline's vertex turns a corner when its horizontal direction changes by more than this
// [rad]: the pulled vertices of a shortened path (straight runs in between).
constexpr double kCornerAngleRad = 0.2;

// Indices of the polyline's corners, ascending, both ends included: vertices where the
// horizontal direction between the neighbouring distinct points turns by more than
// kCornerAngleRad, and the `forced` ones.
std::vector<std::size_t> CornerIndices(const std::vector<Eigen::Vector3d>& path,
                                       std::span<const std::size_t> forced) {
  std::vector<std::size_t> corners = {0};
  const double cos_limit = std::cos(kCornerAngleRad);
  Eigen::Vector2d incoming = Eigen::Vector2d::Zero();
  for (std::size_t k = 1; k + 1 < path.size(); ++k) {
    const Eigen::Vector2d in = (path[k] - path[k - 1]).head<2>();
    if (in.norm() > 1e-9) incoming = in.normalized();
    const Eigen::Vector2d out = (path[k + 1] - path[k]).head<2>();
    if (incoming.isZero() || out.norm() <= 1e-9) continue;
    if (incoming.dot(out.normalized()) < cos_limit) corners.push_back(k);
  }
  if (path.size() > 1) corners.push_back(path.size() - 1);
  corners.insert(corners.end(), forced.begin(), forced.end());
  std::sort(corners.begin(), corners.end());
  corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
  return corners;
}

// Which ends of a trajectory start or stop at rest (or nearly so): ResampleInterior splits
// the piece next to each in two.
struct EndsAtRest {
  bool head = false;
  bool tail = false;
};

// Waypoints along the polyline, excluding both ends: every corner (CornerIndices), and between
// consecutive corners points every ~`spacing_m` of arc length (at least one piece per run).
// Keeping the corners keeps the initial trajectory inside the corridor the path threads,
// where a uniform resampling would cut its corners; *pieces is the number of pieces. The
// `pinned` points are corners too; *pinned_columns gets their indices among the points.
// An end at rest gets one more point, halfway along the piece next to it (its index goes to
// *held_columns): one polynomial over a whole piece is too stiff to speed up from rest at
// anything near the acceleration bound, and a 13 m drive from rest to rest took 1.21 times
// the time of driving it at the speed bound (1.17 split). The optimiser holds these points
// where they are (OptimizationProblem::held_waypoints): left free, it moved them sideways,
// and the trajectory turned while slow (mean curvature over scene20.2's pairs up by 6%). A
// run shorter than a piece, between a corner and the end, is not split: the held point then
// forced a sharp turn at walking pace (s2_flat_diag's mean curvature 0.064 -> 0.104).
std::vector<Eigen::Vector3d> ResampleInterior(const std::vector<Eigen::Vector3d>& path,
                                              double spacing_m, std::span<const std::size_t> pinned,
                                              EndsAtRest at_rest, int* pieces,
                                              std::vector<int>* pinned_columns,
                                              std::vector<int>* held_columns) {
  std::vector<Eigen::Vector3d> points;
  const std::vector<std::size_t> corners = CornerIndices(path, pinned);
  struct Place {
    double along_m;  // Arc length from the run's first corner.
    bool held;
  };
  std::vector<Place> places;  // Of a run's points.
  for (std::size_t c = 0; c + 1 < corners.size(); ++c) {
    double length = 0;
    for (std::size_t k = corners[c] + 1; k <= corners[c + 1]; ++k) {
      length += (path[k] - path[k - 1]).norm();
    }
    const int run_pieces = std::max(1, static_cast<int>(std::lround(length / spacing_m)));
    const double step = length / run_pieces;
    places.clear();
    for (int i = 1; i < run_pieces; ++i) places.push_back({i * step, false});
    const bool first_run = c == 0, last_run = c + 2 == corners.size();
    const bool long_run = length >= spacing_m;
    if (first_run && at_rest.head && long_run) places.push_back({0.5 * step, true});
    // A single piece from rest to rest: its middle serves both ends.
    if (last_run && at_rest.tail && long_run && !(first_run && at_rest.head && run_pieces == 1)) {
      places.push_back({length - 0.5 * step, true});
    }
    std::sort(places.begin(), places.end(),
              [](const Place& a, const Place& b) { return a.along_m < b.along_m; });
    double travelled = 0;
    auto next = places.begin();
    for (std::size_t k = corners[c] + 1; k <= corners[c + 1]; ++k) {
      const double segment = (path[k] - path[k - 1]).norm();
      // The run's last point is the corner itself, added below.
      while (segment > 0 && next != places.end() && travelled + segment >= next->along_m) {
        if (next->held) held_columns->push_back(static_cast<int>(points.size()));
        points.emplace_back(path[k - 1] +
                            (next->along_m - travelled) / segment * (path[k] - path[k - 1]));
        ++next;
      }
      travelled += segment;
    }
    if (!last_run) {
      if (std::binary_search(pinned.begin(), pinned.end(), corners[c + 1])) {
        pinned_columns->push_back(static_cast<int>(points.size()));
      }
      points.push_back(path[corners[c + 1]]);
    }
  }
  *pieces = static_cast<int>(points.size()) + 1;
  return points;
}

// The suitable body height (active-height robots) where the reference point is at p.
double BodyHeightAt(const TrajectoryCost& cost, const Eigen::Vector3d& p) {
  GroundSample ground;
  const double clearance = SampleGround(cost.model(), p, cost.params().profile.reference_height_m,
                                        cost.ClearanceCap(), &ground)
                               ? ground.clearance_m
                               : cost.ClearanceCap();
  return cost.SuitableBodyHeight(clearance, nullptr);
}

// A boundary state as MINCO takes it (dim×3: position, velocity, acceleration), the body
// height (dim 4) the suitable one at the state's position, at rest.
Eigen::MatrixXd BoundaryState(const TrajectoryCost& cost, const RobotState& state) {
  const int dim = cost.params().dim();
  Eigen::MatrixXd pva = Eigen::MatrixXd::Zero(dim, 3);
  pva.col(0).head<3>() = state.position_m;
  pva.col(1).head<3>() = state.velocity_mps;
  pva.col(2).head<3>() = state.acceleration_mps2;
  if (dim == 4) pva(3, 0) = BodyHeightAt(cost, state.position_m);
  return pva;
}

// The time on `trajectory` whose position is nearest p: a scan every kScanStepS, refined
// around the best sample every kScanStepS / 50.
double NearestTime(const Trajectory& trajectory, const Eigen::Vector3d& p) {
  constexpr double kScanStepS = 0.05;
  const double total = trajectory.TotalDuration();
  TrajectoryCursor cursor(trajectory);
  const auto distance = [&](double t) { return (cursor.Position(t).head<3>() - p).norm(); };
  double best_t = 0, best = distance(0);
  for (double t = kScanStepS; t < total + kScanStepS; t += kScanStepS) {
    const double time = std::min(t, total);
    if (const double d = distance(time); d < best) best = d, best_t = time;
  }
  const double from = std::max(0.0, best_t - kScanStepS), to = std::min(total, best_t + kScanStepS);
  for (double t = from; t <= to; t += kScanStepS / 50) {
    if (const double d = distance(t); d < best) best = d, best_t = t;
  }
  return best_t;
}

// Fractions of the profile's bounds a timing plans for.
struct Pace {
  double speed = 0;
  double accel = 0;
};
// The optimiser's initial guess accelerates at this fraction of the bounds: room for turns
// the timing does not see.
constexpr double kInitialAccelFraction = 0.5;
// The fallback: no optimiser will smooth its corners, so slow, and stretched afterwards.
constexpr Pace kFallbackPace{0.4, 0.25};

// The fallback's points sit at the reference height above the ground interpolated between
// columns, and on a voxel map's stepped ground that height can pass a few centimetres under
// the top of a step that the ESDF sees, nearer to it than the verifier allows. Such a point
// rises, a centimetre at a time, until it has kFallbackClearanceMarginM more than the
// verifier's distance, by at most kMaxFallbackLiftM: half the verifier's least ground
// tolerance, so that the lifted point still counts as on the ground.
constexpr double kFallbackClearanceMarginM = 0.03;
constexpr double kMaxFallbackLiftM = 0.05;
Eigen::Vector3d LiftedClear(const TerrainModel& model, const Eigen::Vector3d& p,
                            double min_obstacle_distance_m) {
  const double wanted = min_obstacle_distance_m + kFallbackClearanceMarginM;
  Eigen::Vector3d best = p;
  double best_distance = model.Distance(p);
  for (double lift = 0.01; best_distance < wanted && lift <= kMaxFallbackLiftM + 1e-9;
       lift += 0.01) {
    const Eigen::Vector3d q = p + Eigen::Vector3d(0, 0, lift);
    if (const double d = model.Distance(q); d > best_distance) best = q, best_distance = d;
  }
  return best;
}

// The fallback's body heights (active-height robots), one per point of `points` (start,
// interior points, goal, in path order): the suitable height, lowest within
// kFallbackBodyRampM along the path, then averaged twice over a quarter of that on each side.
// The minimum crouches ahead of a ceiling; the averages turn each of its steps into a rounded
// ramp no longer than kFallbackBodyRampM, which a minimum-jerk curve through the points
// follows without swinging past. Each height stays between the range's bottom and the
// suitable height at its own point: what the averages weigh are minima over windows that
// hold that point. The suitable height of each point instead steps at a table's edge between
// two points a third of a cell apart, and the curve overshot the step by more than the
// verifier allows (forced to the fallback, 6% of the biped's indoor_tables pairs failed on
// headroom or the body's range; once averaged, not twice, and with the ends left at the
// suitable height, 4 of 500 of parking_garage's pairs still undershot the range).
constexpr double kFallbackBodyRampM = 0.5;
std::vector<double> FallbackBodyHeights(const TrajectoryCost& cost,
                                        const std::vector<Eigen::Vector3d>& points) {
  const std::size_t n = points.size();
  std::vector<double> along(n, 0.0), suitable(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0) along[k] = along[k - 1] + (points[k] - points[k - 1]).norm();
    suitable[k] = BodyHeightAt(cost, points[k]);
  }
  // Over the points within `reach` of point k along the path (a window that slides forward).
  const auto over_window = [&](double reach, const std::vector<double>& values, auto combine) {
    std::vector<double> result(n);
    std::size_t first = 0, last = 0;
    for (std::size_t k = 0; k < n; ++k) {
      while (along[k] - along[first] > reach) ++first;
      while (last + 1 < n && along[last + 1] - along[k] <= reach) ++last;
      result[k] = combine(values.begin() + static_cast<std::ptrdiff_t>(first),
                          values.begin() + static_cast<std::ptrdiff_t>(last) + 1);
    }
    return result;
  };
  const auto mean = [](auto from, auto to) {
    return std::accumulate(from, to, 0.0) / static_cast<double>(to - from);
  };
  const std::vector<double> lowest = over_window(
      kFallbackBodyRampM, suitable, [](auto from, auto to) { return *std::min_element(from, to); });
  return over_window(kFallbackBodyRampM / 4, over_window(kFallbackBodyRampM / 4, lowest, mean),
                     mean);
}

// Durations of the pieces between start, the interior points and goal: a trapezoidal speed
// profile over the arc length (accelerate from the start's speed, cruise, brake to the
// goal's), the cruise speed on each piece lowered where its slope would take the vertical
// speed past its bound.
Eigen::VectorXd InitialDurations(const CostParams& params, const RobotState& start,
                                 const RobotState& goal,
                                 const std::vector<Eigen::Vector3d>& interior, Pace pace) {
  const RobotProfile& robot = params.profile;
  std::vector<Eigen::Vector3d> points;
  points.reserve(interior.size() + 2);
  points.push_back(start.position_m);
  points.insert(points.end(), interior.begin(), interior.end());
  points.push_back(goal.position_m);
  const int pieces = static_cast<int>(points.size()) - 1;
  std::vector<double> along(points.size(), 0.0);  // Horizontal arc length [m].
  for (std::size_t k = 1; k < points.size(); ++k) {
    along[k] = along[k - 1] + (points[k] - points[k - 1]).head<2>().norm();
  }
  const double total = along.back();
  const double accel = pace.accel * robot.max_accel_horizontal_mps2;
  const double v0 = start.velocity_mps.head<2>().norm(), v1 = goal.velocity_mps.head<2>().norm();
  // Corners: a turn of θ between pieces of horizontal length ℓ taken at speed v accelerates
  // sideways by about v²·θ/ℓ, so the timing slows to where that is the pace's acceleration.
  // A guess that turns at full speed overshoots its corners and leaves the optimiser a wave
  // to iron out along the straight that follows.
  struct Corner {
    double along_m, speed_mps;
  };
  std::vector<Corner> corners;
  for (std::size_t k = 1; k + 1 < points.size(); ++k) {
    const Eigen::Vector2d in = (points[k] - points[k - 1]).head<2>();
    const Eigen::Vector2d out = (points[k + 1] - points[k]).head<2>();
    const double shorter = std::min(in.norm(), out.norm());
    if (shorter <= 1e-9) continue;
    const double turn = std::acos(std::clamp(in.normalized().dot(out.normalized()), -1.0, 1.0));
    if (turn > kCornerAngleRad) corners.push_back({along[k], std::sqrt(accel * shorter / turn)});
  }
  // The trapezoid's speed at horizontal arc length s, before slopes.
  const auto speed_at = [&](double s) {
    double v =
        std::min({pace.speed * robot.max_speed_horizontal_mps, std::sqrt(v0 * v0 + 2 * accel * s),
                  std::sqrt(v1 * v1 + 2 * accel * std::max(0.0, total - s))});
    for (const Corner& c : corners) {
      v = std::min(v, std::sqrt(c.speed_mps * c.speed_mps + 2 * accel * std::abs(s - c.along_m)));
    }
    return v;
  };
  Eigen::VectorXd durations(pieces);
  constexpr int kSubsteps = 4;  // Midpoint rule within a piece.
  for (int k = 0; k < pieces; ++k) {
    const Eigen::Vector3d delta = points[k + 1] - points[k];
    const double horizontal = delta.head<2>().norm();
    // On a slope, the horizontal speed at which the vertical speed meets its bound.
    const double slope_cap = horizontal > 0 ? pace.speed * robot.max_speed_vertical_mps *
                                                  horizontal / std::max(std::abs(delta.z()), 1e-9)
                                            : 0;
    double t = 0;
    for (int j = 0; j < kSubsteps; ++j) {
      const double s = along[k] + (j + 0.5) / kSubsteps * horizontal;
      const double v = std::max(std::min(speed_at(s), slope_cap), 1e-3);
      t += horizontal / kSubsteps / v;
    }
    // A vertical move (no horizontal length): its own bound.
    t = std::max(t, std::abs(delta.z()) / (pace.speed * robot.max_speed_vertical_mps));
    durations(k) = std::max(t, 0.1);
  }
  return durations;
}

}  // namespace

Status OptimizerConfig::Validate(std::string_view path) const {
  if (Status s = weights.Validate(internal::FieldPath(path, "weights")); !s) return s;
  const auto bad_field = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (Status s = cost.Validate(internal::FieldPath(path, "cost")); !s) return s;
  if (!(std::isfinite(piece_length_m) && piece_length_m > 0)) {
    return bad_field("piece_length_m", piece_length_m, "> 0 and finite");
  }
  if (!(initial_speed_fraction > 0 && initial_speed_fraction <= 1)) {
    return bad_field("initial_speed_fraction", initial_speed_fraction, "in (0, 1]");
  }
  if (max_iterations < 1) return bad_field("max_iterations", max_iterations, ">= 1");
  if (!(std::isfinite(gradient_tolerance) && gradient_tolerance > 0)) {
    return bad_field("gradient_tolerance", gradient_tolerance, "> 0 and finite");
  }
  if (!(std::isfinite(relative_improvement_tolerance) && relative_improvement_tolerance >= 0)) {
    return bad_field("relative_improvement_tolerance", relative_improvement_tolerance,
                     ">= 0 and finite");
  }
  if (memory < 1) return bad_field("memory", memory, ">= 1");
  return Status::Ok();
}

OptimizationProblem MakeInitialProblem(const TrajectoryCost& cost,
                                       const std::vector<Eigen::Vector3d>& path_m,
                                       const RobotState& start, const RobotState& goal,
                                       const OptimizerConfig& config,
                                       std::span<const std::size_t> pinned) {
  const CostParams& params = cost.params();
  const int dim = params.dim();
  int pieces = 1;
  OptimizationProblem problem;
  // At rest: slower than the initial timing gets in half a piece from rest.
  const double rest_speed = std::sqrt(
      kInitialAccelFraction * params.profile.max_accel_horizontal_mps2 * config.piece_length_m);
  const EndsAtRest at_rest{start.velocity_mps.head<2>().norm() < rest_speed,
                           goal.velocity_mps.head<2>().norm() < rest_speed};
  const std::vector<Eigen::Vector3d> interior =
      ResampleInterior(path_m, config.piece_length_m, pinned, at_rest, &pieces,
                       &problem.pinned_waypoints, &problem.held_waypoints);

  problem.head_pva = BoundaryState(cost, start);
  problem.tail_pva = BoundaryState(cost, goal);
  problem.initial_waypoints.resize(dim, pieces - 1);
  for (int k = 0; k < pieces - 1; ++k) {
    problem.initial_waypoints.col(k).head<3>() = interior[static_cast<std::size_t>(k)];
    if (dim == 4)
      problem.initial_waypoints(3, k) = BodyHeightAt(cost, interior[static_cast<std::size_t>(k)]);
  }
  problem.initial_durations = InitialDurations(
      params, start, goal, interior, Pace{config.initial_speed_fraction, kInitialAccelFraction});
  return problem;
}

OptimizationProblem MakeFallbackProblem(const TrajectoryCost& cost,
                                        const std::vector<Eigen::Vector3d>& path_m,
                                        const RobotState& start, const RobotState& goal,
                                        double min_obstacle_distance_m,
                                        std::span<const std::size_t> pinned) {
  const int dim = cost.params().dim();
  OptimizationProblem problem;
  // Every point of the path but its ends, which start and goal replace, and between them
  // points every third of a cell on the ground: a MINCO curve through points a cell apart
  // swings out at a right-angled corner of a one-column passage far enough to clip the
  // missing column beside it, through points a third as far apart three times less.
  const double spacing = cost.graph().grid().resolution_m / 3;
  const double h_ref = cost.params().profile.reference_height_m;
  // Every point but a pinned one at the reference height above the ground the verifier
  // measures, interpolated between columns, and lifted clear. A path point is a node's column
  // centre at the node's height, which is its column's ground: beside a ramp's toe that was
  // 0.12 m above the interpolated ground, and the verifier failed the fallback there (45% of
  // two_level_ramp's pairs for the biped, 6% for the differential robot, forced to the fallback).
  const auto on_ground = [&](Eigen::Vector3d p) {
    GroundSample ground;
    if (SampleGround(cost.model(), p, h_ref, 0, &ground)) p.z() = ground.height_m + h_ref;
    return LiftedClear(cost.model(), p, min_obstacle_distance_m);
  };
  std::vector<Eigen::Vector3d> interior;
  for (std::size_t k = 1; k < path_m.size(); ++k) {
    const Eigen::Vector3d from = k == 1 ? start.position_m : path_m[k - 1];
    const Eigen::Vector3d to = k + 1 == path_m.size() ? goal.position_m : path_m[k];
    const int steps =
        std::max(1, static_cast<int>(std::ceil((to - from).head<2>().norm() / spacing)));
    for (int j = 1; j < steps; ++j) {
      interior.push_back(on_ground(from + (to - from) * (static_cast<double>(j) / steps)));
    }
    if (k + 1 < path_m.size()) {
      if (std::binary_search(pinned.begin(), pinned.end(), k)) {
        problem.pinned_waypoints.push_back(static_cast<int>(interior.size()));
        interior.push_back(path_m[k]);
      } else {
        interior.push_back(on_ground(path_m[k]));
      }
    }
  }
  problem.head_pva = BoundaryState(cost, start);
  problem.tail_pva = BoundaryState(cost, goal);
  problem.initial_waypoints.resize(dim, static_cast<Eigen::Index>(interior.size()));
  for (std::size_t k = 0; k < interior.size(); ++k) {
    problem.initial_waypoints.col(static_cast<Eigen::Index>(k)).head<3>() = interior[k];
  }
  if (dim == 4) {
    std::vector<Eigen::Vector3d> points = {start.position_m};
    points.insert(points.end(), interior.begin(), interior.end());
    points.push_back(goal.position_m);
    const std::vector<double> body = FallbackBodyHeights(cost, points);
    problem.head_pva(3, 0) = body.front();
    problem.tail_pva(3, 0) = body.back();
    for (std::size_t k = 0; k < interior.size(); ++k) {
      problem.initial_waypoints(3, static_cast<Eigen::Index>(k)) = body[k + 1];
    }
  }
  problem.initial_durations = InitialDurations(cost.params(), start, goal, interior, kFallbackPace);
  return problem;
}

Expected<OptimizationProblem> MakeWarmProblem(const TrajectoryCost& cost, const WarmStart& warm,
                                              const RobotState& start, const RobotState& goal) {
  const Trajectory& previous = warm.trajectory;
  const int dim = cost.params().dim();
  const auto refuse = [](const std::string& why) {
    return Error{ErrorCode::kInvalidInput, "the warm start does not fit this plan: " + why};
  };
  if (previous.pieces.empty() || previous.dimension != dim) {
    return refuse(
        fmt::format("its trajectory has {} pieces of dimension {}, this robot's have "
                    "dimension {}",
                    previous.pieces.size(), previous.dimension, dim));
  }
  const double total = previous.TotalDuration();
  const double now = warm.elapsed_s >= 0 ? std::min(warm.elapsed_s, total)
                                         : NearestTime(previous, start.position_m);
  const double off_start = (previous.Position(now).head<3>() - start.position_m).norm();
  const double off_goal = (previous.Position(total).head<3>() - goal.position_m).norm();
  if (off_start > kWarmStartToleranceM || off_goal > kWarmStartToleranceM) {
    return refuse(
        fmt::format("the start is {:.2f} m and the goal {:.2f} m from it (at most "
                    "{:.2f} m each)",
                    off_start, off_goal, kWarmStartToleranceM));
  }
  // The piece the robot is on, and how far into it.
  std::size_t piece = 0;
  double into = now;
  while (piece + 1 < previous.pieces.size() && into >= previous.pieces[piece].duration_s) {
    into -= previous.pieces[piece].duration_s;
    ++piece;
  }
  // What is left of it becomes the first piece; a stub of it merges with the next.
  double first = std::max(previous.pieces[piece].duration_s - into, 0.0);
  std::size_t next = piece + 1;
  if (first < 0.3 * previous.pieces[piece].duration_s && next < previous.pieces.size()) {
    first += previous.pieces[next++].duration_s;
  }
  const std::size_t remaining = 1 + previous.pieces.size() - next;
  OptimizationProblem problem;
  problem.head_pva = BoundaryState(cost, start);
  problem.tail_pva = BoundaryState(cost, goal);
  if (dim == 4) problem.head_pva(3, 0) = previous.Position(now)(3);  // Where the body is now.
  problem.initial_waypoints.resize(dim, static_cast<Eigen::Index>(remaining) - 1);
  problem.initial_durations.resize(static_cast<Eigen::Index>(remaining));
  problem.initial_durations(0) = std::max(first, 0.05);
  for (std::size_t k = next; k < previous.pieces.size(); ++k) {
    const auto column = static_cast<Eigen::Index>(k - next);
    problem.initial_waypoints.col(column) = previous.pieces[k].coefficients.row(0).transpose();
    problem.initial_durations(column + 1) = previous.pieces[k].duration_s;
  }
  return problem;
}

Expected<OptimizationReport> OptimizeTrajectory(const TrajectoryCost& cost,
                                                const OptimizationProblem& problem,
                                                const OptimizerConfig& config,
                                                const std::function<bool()>& should_stop,
                                                Minco3* minco) {
  if (Status s = config.Validate(); !s) return s.error();
  const int pieces = static_cast<int>(problem.initial_durations.size());
  minco->SetConditions(problem.head_pva, problem.tail_pva, pieces);

  Eigen::VectorXd x = internal::InitialDecisionVector(problem);

  LBFGSpp::LBFGSParam<double> param;
  param.m = config.memory;
  param.epsilon = config.gradient_tolerance;
  param.epsilon_rel = config.gradient_tolerance;
  param.past = 3;
  param.delta = config.relative_improvement_tolerance;
  param.max_linesearch = 32;
  // Backtracking to the (weak) Wolfe conditions: about one evaluation per iteration here, and
  // the curvature condition keeps the L-BFGS update positive definite.
  param.linesearch = LBFGSpp::LBFGS_LINESEARCH_BACKTRACKING_WOLFE;

  std::vector<int> fixed = problem.pinned_waypoints;  // Pinned and held alike.
  fixed.insert(fixed.end(), problem.held_waypoints.begin(), problem.held_waypoints.end());
  std::sort(fixed.begin(), fixed.end());
  internal::OptimizerObjective objective(cost, minco, should_stop, fixed);
  OptimizationReport report;
  Eigen::VectorXd scratch;
  try {
    report.initial_cost = objective(x, scratch);
    // A line search that cannot meet the Wolfe conditions (a cliff of a cubic penalty from a
    // poor start) ends an L-BFGS run by an exception; restarting from the best point with a
    // fresh memory gets past it. Restarts stop when one makes no progress.
    double previous_best = objective.best_value();
    int iterations_left = config.max_iterations;
    for (int run = 0; run < kMaxRestarts && iterations_left > 0; ++run) {
      param.max_iterations = iterations_left;
      LBFGSpp::LBFGSSolver<double, LBFGSpp::LineSearchBacktracking> solver(param);
      x = objective.best_x();
      double value = 0;
      try {
        const int iterations = solver.minimize(objective, x, value);
        report.iterations += iterations;
        report.converged = iterations < iterations_left;
        break;
      } catch (const internal::StopRequested&) {
        throw;
      } catch (const std::exception&) {
        // The failed run's iterations are not reported; count the evaluations it used.
        iterations_left -= std::max(1, objective.evaluations() - report.evaluations);
        report.evaluations = objective.evaluations();
        ++report.iterations;
      }
      if (!(objective.best_value() < previous_best * (1 - config.relative_improvement_tolerance)))
        break;
      previous_best = objective.best_value();
    }
  } catch (const internal::StopRequested&) {
    return Error{ErrorCode::kCancelled, "trajectory optimisation stopped by the caller"};
  }
  // Leave *minco at the best point evaluated (the solver's last evaluation may be a trial).
  objective.Apply(objective.best_x());
  report.evaluations = objective.evaluations();
  Eigen::MatrixXd grad_c;
  report.final_cost = cost.Evaluate(*minco, &grad_c, &scratch, &report.final_terms);
  return report;
}

}  // namespace strata
