#include "strata/verification/trajectory_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planning/terrain_query.hpp"

namespace strata {
namespace {

// "at t = 12.34 s, (x, y, z): <what>".
Error Violation(double t, const Eigen::Vector3d& p, const std::string& what) {
  return Error{ErrorCode::kOptimizationFailed,
               fmt::format("trajectory verification failed at t = {:.3f} s, {}: {}", t,
                           internal::FormatPoint(p), what)};
}

std::string Exceeds(const char* quantity, double value, double bound, const char* unit) {
  return fmt::format("{} {:.4g} {} exceeds the bound {:.4g} {}", quantity, value, unit, bound,
                     unit);
}

// Largest speed of the x, y, z path, from 32 samples per piece; only sets the step size.
double PeakSpeed(const Trajectory& trajectory) {
  double peak = 0;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double duration = trajectory.pieces[i].duration_s;
    for (int k = 0; k <= 32; ++k) {
      peak = std::max(peak, trajectory.EvaluatePiece(i, duration * k / 32, 1).head<3>().norm());
    }
  }
  return peak;
}

// Column edges one step between samples (<= max_sample_spacing_m) may cross: more than a
// corner's worth only on a curve that winds within one step.
constexpr int kMaxCrossingsPerStep = 4;

// Most samples one verification takes (2e7 samples 2 cm apart: 400 km).
constexpr double kMaxSamples = 2e7;

constexpr double kDegree = std::numbers::pi / 180.0;

// `surface` if it is one of column `cell`'s surfaces, else nullptr.
const ColumnSurface* SurfaceOfColumn(const TerrainModel& model, const Eigen::Vector3i& cell,
                                     const ColumnSurface* surface) {
  for (const ColumnSurface& s : model.surfaces().Column(cell.x(), cell.y())) {
    if (&s == surface) return surface;
  }
  return nullptr;
}

// Whether `graph` has a node on `surface` in column `cell`.
bool HasNodeOn(const SurfaceGraph& graph, const Eigen::Vector3i& cell,
               const ColumnSurface* surface) {
  for (const std::int32_t node : graph.ColumnNodes(cell.x(), cell.y())) {
    if (&graph.surface(node) == surface) return true;
  }
  return false;
}

}  // namespace

Status VerifierConfig::Validate(std::string_view path) const {
  if (!(std::isfinite(max_sample_spacing_m) && max_sample_spacing_m > 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_sample_spacing_m"),
                                max_sample_spacing_m, "> 0");
  }
  if (!(std::isfinite(ground_tolerance_m) && ground_tolerance_m > 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "ground_tolerance_m"), ground_tolerance_m,
                                "> 0");
  }
  if (!(std::isfinite(min_obstacle_distance_m) && min_obstacle_distance_m >= 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "min_obstacle_distance_m"),
                                min_obstacle_distance_m, ">= 0");
  }
  if (!(std::isfinite(limit_tolerance) && limit_tolerance >= 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "limit_tolerance"), limit_tolerance,
                                ">= 0");
  }
  return Status::Ok();
}

double BodyHeightTolerance(const RobotProfile& profile, const VerifierConfig& config) {
  return config.limit_tolerance *
         (profile.active_height ? profile.body_height_max_m : profile.body_height_m);
}

namespace {

// The checks of one state, one function per rule of VerifyTrajectory's list, in its order,
// each recording its figure in the report first. Every comparison is written
// !(value within bound), so a NaN fails it.
class StateChecker {
 public:
  StateChecker(const SurfaceGraph& graph, const RobotProfile& profile, const VerifierConfig& config,
               std::span<const KeepOutZone> keep_out, VerificationReport* report)
      : graph_(graph),
        model_(graph.model()),
        grid_(graph.grid()),
        profile_(profile),
        config_(config),
        keep_out_(keep_out),
        report_(report),
        tolerance_(1 + config.limit_tolerance),
        body_slack_m_(BodyHeightTolerance(profile, config)),
        // A voxelised cloud knows its ground only to within half a quantum; the check allows
        // that plus a quarter quantum of tracking, or every staircase ramp would fail it by
        // noise.
        ground_tolerance_m_(
            std::max(config.ground_tolerance_m, 0.75 * model_.summary().vertical_quantum_m)),
        // How far the plane-fit ground at the centre of the robot's own column may lie from
        // its feet: the ground tolerance plus the rise from the centre to a corner of the
        // column on the steepest slope the robot may stand on.
        level_tolerance_m_(ground_tolerance_m_ +
                           grid_.resolution_m / std::sqrt(2.0) * std::tan(profile.max_tilt_rad)),
        grid_max_(grid_.origin_m + grid_.size.cast<double>() * grid_.resolution_m) {}

  // Every rule at time t, in order; the first violation.
  Status Check(double t, const StateVector& pos, const StateVector& vel, const StateVector& acc) {
    const Eigen::Vector3d p = pos.head<3>();
    ++report_->samples;
    if (Status s = Kinematics(t, p, vel, acc); !s) return s;
    if (Status s = InsideGrid(t, p); !s) return s;
    GroundSample ground;
    const Eigen::Vector3i cell = grid_.CellOf(p);
    if (Status s = GroundOfOwnColumn(t, p, cell, &ground); !s) return s;
    const ColumnSurface& surface = *ground.surface;
    if (Status s = GroundAtRobotsLevel(t, p, surface); !s) return s;
    if (Status s = ValidGround(t, p, surface); !s) return s;
    if (Status s = Tilt(t, p, surface); !s) return s;
    if (Status s = GroundOffset(t, p, ground); !s) return s;
    if (Status s = ObstacleDistance(t, p); !s) return s;
    const double body = profile_.active_height ? pos(3) : profile_.body_height_m;
    if (Status s = Headroom(t, p, surface, body); !s) return s;
    if (Status s = BodyHeightRange(t, p, body); !s) return s;
    if (Status s = GraphNode(t, p, cell, ground.surface); !s) return s;
    return KeepOut(t, p);
  }

 private:
  // Horizontal and vertical speed and acceleration within the profile's bounds.
  Status Kinematics(double t, const Eigen::Vector3d& p, const StateVector& vel,
                    const StateVector& acc) {
    const double speed_h = vel.head<2>().norm(), speed_v = std::abs(vel(2));
    const double accel_h = acc.head<2>().norm(), accel_v = std::abs(acc(2));
    report_->max_speed_horizontal_mps = std::max(report_->max_speed_horizontal_mps, speed_h);
    report_->max_speed_vertical_mps = std::max(report_->max_speed_vertical_mps, speed_v);
    report_->max_accel_horizontal_mps2 = std::max(report_->max_accel_horizontal_mps2, accel_h);
    report_->max_accel_vertical_mps2 = std::max(report_->max_accel_vertical_mps2, accel_v);
    if (!(speed_h <= tolerance_ * profile_.max_speed_horizontal_mps)) {
      return Violation(
          t, p, Exceeds("horizontal speed", speed_h, profile_.max_speed_horizontal_mps, "m/s"));
    }
    if (!(speed_v <= tolerance_ * profile_.max_speed_vertical_mps)) {
      return Violation(t, p,
                       Exceeds("vertical speed", speed_v, profile_.max_speed_vertical_mps, "m/s"));
    }
    if (!(accel_h <= tolerance_ * profile_.max_accel_horizontal_mps2)) {
      return Violation(
          t, p,
          Exceeds("horizontal acceleration", accel_h, profile_.max_accel_horizontal_mps2, "m/s^2"));
    }
    if (!(accel_v <= tolerance_ * profile_.max_accel_vertical_mps2)) {
      return Violation(
          t, p,
          Exceeds("vertical acceleration", accel_v, profile_.max_accel_vertical_mps2, "m/s^2"));
    }
    return Status::Ok();
  }

  Status InsideGrid(double t, const Eigen::Vector3d& p) const {
    if (!((p.array() >= grid_.origin_m.array()).all() && (p.array() < grid_max_.array()).all())) {
      return Violation(t, p, "no ground: the reference point is outside the map's grid");
    }
    return Status::Ok();
  }

  // The surface the robot stands on is the one of its own column nearest to its feet
  // (SampleGround), never another level of that column (the deck above a passage too low for
  // it).
  Status GroundOfOwnColumn(double t, const Eigen::Vector3d& p, const Eigen::Vector3i& cell,
                           GroundSample* ground) {
    if (!SampleGround(model_, p, profile_.reference_height_m, 0, ground, &ground_choice_) ||
        SurfaceOfColumn(model_, cell, ground->surface) == nullptr) {
      return Violation(t, p, "no ground in the column below the reference point");
    }
    return Status::Ok();
  }

  // The column's nearest surface may be another level: the top of a post, a table leg or a
  // wall the reference point is inside of, while the smoothed ground comes from the columns
  // around.
  Status GroundAtRobotsLevel(double t, const Eigen::Vector3d& p,
                             const ColumnSurface& surface) const {
    const double feet_m = p.z() - profile_.reference_height_m;
    if (!(std::abs(surface.plane_center_z_m - feet_m) <= level_tolerance_m_)) {
      return Violation(t, p,
                       fmt::format("no ground in the column below at the robot's level: its "
                                   "nearest surface is {:.3f} m from the reference point's "
                                   "ground height {:.3f} m (more than {:.3f} m; a post, a "
                                   "table leg or a wall?)",
                                   surface.plane_center_z_m - feet_m, feet_m, level_tolerance_m_));
    }
    return Status::Ok();
  }

  static Status ValidGround(double t, const Eigen::Vector3d& p, const ColumnSurface& surface) {
    if (!surface.valid) {
      return Violation(t, p,
                       "the ground below is not valid ground (the Valid Ground Filter found "
                       "an obstacle, an overhang or a steep rise within its radius)");
    }
    return Status::Ok();
  }

  Status Tilt(double t, const Eigen::Vector3d& p, const ColumnSurface& surface) {
    const double tilt = surface.tilt_rad;
    report_->max_tilt_rad = std::max(report_->max_tilt_rad, tilt);
    if (!(tilt <= profile_.max_tilt_rad)) {
      return Violation(
          t, p, Exceeds("ground tilt", tilt / kDegree, profile_.max_tilt_rad / kDegree, "deg"));
    }
    return Status::Ok();
  }

  // z within the ground tolerance of the smoothed ground + the reference height.
  Status GroundOffset(double t, const Eigen::Vector3d& p, const GroundSample& ground) {
    const double offset = p.z() - ground.height_m - profile_.reference_height_m;
    report_->max_ground_offset_m = std::max(report_->max_ground_offset_m, std::abs(offset));
    if (!(std::abs(offset) <= ground_tolerance_m_)) {
      return Violation(t, p,
                       Exceeds("distance from the reference height above ground", std::abs(offset),
                               ground_tolerance_m_, "m"));
    }
    return Status::Ok();
  }

  Status ObstacleDistance(double t, const Eigen::Vector3d& p) {
    const double distance = model_.Distance(p);
    report_->min_obstacle_distance_m = std::min(report_->min_obstacle_distance_m, distance);
    if (!(distance >= config_.min_obstacle_distance_m)) {
      return Violation(t, p,
                       fmt::format("obstacle distance {:.3f} m is below {:.3f} m", distance,
                                   config_.min_obstacle_distance_m));
    }
    return Status::Ok();
  }

  // The body under the ceiling with the profile's headroom above it.
  Status Headroom(double t, const Eigen::Vector3d& p, const ColumnSurface& surface, double body) {
    const double clearance = surface.clearance_m;
    report_->min_body_height_m = std::min(report_->min_body_height_m, body);
    report_->min_headroom_m = std::min(report_->min_headroom_m, clearance - body);
    if (!(body + profile_.headroom_m <= clearance + body_slack_m_)) {
      return Violation(t, p,
                       fmt::format("headroom {:.3f} m between the body (height {:.3f} m) and "
                                   "the ceiling ({:.3f} m above ground) is below the profile's "
                                   "headroom_m {:.3f} m",
                                   clearance - body, body, clearance, profile_.headroom_m));
    }
    return Status::Ok();
  }

  // A commanded body height within the profile's range.
  Status BodyHeightRange(double t, const Eigen::Vector3d& p, double body) const {
    if (profile_.active_height && !(body <= profile_.body_height_max_m + body_slack_m_ &&
                                    body >= profile_.body_height_min_m - body_slack_m_)) {
      return Violation(t, p,
                       fmt::format("body height {:.3f} m is outside [{:.3f}, {:.3f}] m", body,
                                   profile_.body_height_min_m, profile_.body_height_max_m));
    }
    return Status::Ok();
  }

  // The graph the path was searched on must hold this surface too (it does when it was built
  // from profile.Traversability(); another robot's graph may not).
  Status GraphNode(double t, const Eigen::Vector3d& p, const Eigen::Vector3i& cell,
                   const ColumnSurface* surface) const {
    if (!HasNodeOn(graph_, cell, surface)) {
      return Violation(t, p,
                       "the ground below is not a node of the traversability graph (a graph "
                       "built for other traversability parameters than this profile's?)");
    }
    return Status::Ok();
  }

  Status KeepOut(double t, const Eigen::Vector3d& p) const {
    if (const int zone = FirstViolatedKeepOut(keep_out_, profile_, p); zone >= 0) {
      return Violation(t, p,
                       fmt::format("inside {}: the footprint (radius {:.3f} m) reaches {:.3f} m "
                                   "into its polygon within its height range",
                                   keep_out_[zone].name, profile_.footprint_radius_m,
                                   KeepOutPenetration(keep_out_[zone].prism, profile_, p)));
    }
    return Status::Ok();
  }

  const SurfaceGraph& graph_;
  const TerrainModel& model_;
  const GridGeometry& grid_;
  const RobotProfile& profile_;
  const VerifierConfig& config_;
  std::span<const KeepOutZone> keep_out_;
  VerificationReport* report_;
  const double tolerance_;
  const double body_slack_m_;
  const double ground_tolerance_m_;
  const double level_tolerance_m_;
  const Eigen::Vector3d grid_max_;
  // Consecutive samples, 2 cm apart, mostly stand on the same column corners: SampleGround
  // reuses their choice where it holds (the same answers, fewer column scans).
  GroundChoice ground_choice_;
};

// The trajectory's shape before anything is sampled: the profile's dimension, pieces with
// finite coefficients and finite positive durations.
Status CheckShape(const Trajectory& trajectory, const RobotProfile& profile) {
  const int dimension = profile.active_height ? 4 : 3;
  if (trajectory.dimension != dimension) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("trajectory has dimension {} but profile '{}' needs {} (x, y, z{})",
                             trajectory.dimension, profile.name, dimension,
                             profile.active_height ? ", body height" : "")};
  }
  if (trajectory.pieces.empty()) {
    return Error{ErrorCode::kOptimizationFailed, "trajectory verification failed: no pieces"};
  }
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[i];
    if (piece.coefficients.cols() != dimension) {
      return Error{ErrorCode::kInvalidInput,
                   fmt::format("trajectory piece {} has {} axes, the trajectory {}", i,
                               piece.coefficients.cols(), dimension)};
    }
    // Everything below evaluates these; a NaN would also make the step count undefined.
    if (!(std::isfinite(piece.duration_s) && piece.duration_s > 0) ||
        !piece.coefficients.allFinite()) {
      return Error{ErrorCode::kOptimizationFailed,
                   fmt::format("trajectory verification failed: piece {} has duration {:g} s "
                               "and {} coefficients; both must be finite, the duration > 0",
                               i, piece.duration_s,
                               piece.coefficients.allFinite() ? "finite" : "non-finite")};
    }
  }
  return Status::Ok();
}

// Where the reference point changed columns between `from` and `to`, the state at its first
// instant in each column entered (bisection to 1e-9 s): a ceiling, the ground's validity and
// the graph's nodes change at column edges, not between samples.
Status CheckColumnEntries(double from, double to, const GridGeometry& grid,
                          TrajectoryCursor& cursor, StateChecker& checker) {
  // The column at global time t (floored cell coordinates, as doubles so that no cast can
  // overflow).
  const auto column_at = [&](double t) -> Eigen::Vector2d {
    const Eigen::Vector2d p = cursor.Position(t).head<2>();
    return ((p - grid.origin_m.head<2>()) / grid.resolution_m).array().floor();
  };
  const Eigen::Vector2d target = column_at(to);
  Eigen::Vector2d column = column_at(from);
  for (int crossings = 0; column != target && crossings < kMaxCrossingsPerStep; ++crossings) {
    // column_at(mid) == column, by comparisons: the halvings wait on each other, and a
    // division and a floor were most of each one.
    const GridGeometry::OffsetRange x = grid.OffsetsOfIndex(column.x());
    const GridGeometry::OffsetRange y = grid.OffsetsOfIndex(column.y());
    const auto in_column = [&](double time) {
      const Eigen::Vector2d d = cursor.Position(time).head<2>() - grid.origin_m.head<2>();
      return d.x() >= x.low && d.x() < x.high && d.y() >= y.low && d.y() < y.high;
    };
    double lo = from, hi = to;
    for (int halving = 0; halving < 60 && hi - lo > 1e-9; ++halving) {
      const double mid = 0.5 * (lo + hi);
      (in_column(mid) ? lo : hi) = mid;
    }
    if (Status s =
            checker.Check(hi, cursor.Position(hi), cursor.Velocity(hi), cursor.Acceleration(hi));
        !s) {
      return s;
    }
    from = hi;
    column = column_at(hi);
  }
  return Status::Ok();
}

}  // namespace

Status VerifyTrajectory(const SurfaceGraph& graph, const RobotProfile& profile,
                        const Trajectory& trajectory, const VerifierConfig& config,
                        VerificationReport* report, std::span<const KeepOutZone> keep_out,
                        const Traffic* traffic) {
  if (Status s = config.Validate(); !s) return s;
  if (Status s = profile.Validate(); !s) return s;
  if (traffic != nullptr) {
    if (Status s = traffic->rule.Validate("traffic.rule"); !s) return s;
    if (Status s = traffic->body.Validate("traffic.body"); !s) return s;
  }
  *report = VerificationReport{};
  report->min_obstacle_distance_m = std::numeric_limits<double>::infinity();
  report->min_body_height_m = std::numeric_limits<double>::infinity();
  report->min_headroom_m = std::numeric_limits<double>::infinity();
  if (Status s = CheckShape(trajectory, profile); !s) return s;
  // Speed is at most ~1.1× the coarse peak between coarse samples of a quintic (and the 1%
  // limit check bounds it anyway), so this step keeps consecutive samples <= the spacing.
  const double peak_speed = 1.1 * PeakSpeed(trajectory);
  const double sample_count = peak_speed * trajectory.TotalDuration() / config.max_sample_spacing_m;
  if (!(sample_count <= kMaxSamples)) {
    return Error{ErrorCode::kOptimizationFailed,
                 fmt::format("trajectory verification failed: {:.3g} samples {:.3g} m apart are "
                             "too many (at most {:.0f}); the trajectory is too long or too fast",
                             sample_count, config.max_sample_spacing_m, kMaxSamples)};
  }
  StateChecker checker(graph, profile, config, keep_out, report);
  // Between samples (the column entries) the cursor finds the piece from the last one.
  TrajectoryCursor cursor(trajectory);
  double piece_start = 0;
  double previous_t = -1;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double piece_duration = trajectory.pieces[i].duration_s;
    const int steps = std::max(
        1, static_cast<int>(std::ceil(piece_duration * peak_speed / config.max_sample_spacing_m)));
    // Each piece's samples include its start; the last piece also its end.
    const int last = i + 1 == trajectory.pieces.size() ? steps : steps - 1;
    for (int k = 0; k <= last; ++k) {
      const double local_t = piece_duration * k / steps;
      const double t = piece_start + local_t;
      if (previous_t >= 0) {
        if (Status s = CheckColumnEntries(previous_t, t, graph.grid(), cursor, checker); !s) {
          return s;
        }
      }
      if (Status s = checker.Check(t, trajectory.EvaluatePiece(i, local_t, 0),
                                   trajectory.EvaluatePiece(i, local_t, 1),
                                   trajectory.EvaluatePiece(i, local_t, 2));
          !s) {
        return s;
      }
      previous_t = t;
    }
    piece_start += piece_duration;
  }
  if (traffic != nullptr) {
    return CheckSeparation(traffic->MotionOf(trajectory), traffic->others, traffic->rule);
  }
  return Status::Ok();
}

double MeanCurvature(const Trajectory& trajectory, int samples) {
  if (trajectory.pieces.empty() || samples < 1) return 0;
  const double duration = trajectory.TotalDuration();
  double sum = 0;
  int counted = 0;
  TrajectoryCursor cursor(trajectory);
  for (int k = 0; k < samples; ++k) {
    const double t = duration * (k + 0.5) / samples;
    const Eigen::Vector3d v = cursor.Velocity(t).head<3>();
    const Eigen::Vector3d a = cursor.Acceleration(t).head<3>();
    const double speed = v.norm();
    if (speed < 0.01) continue;
    sum += v.cross(a).norm() / (speed * speed * speed);
    ++counted;
  }
  return counted > 0 ? sum / counted : 0;
}

double PathLength(const Trajectory& trajectory) {
  double length = 0;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double duration = trajectory.pieces[i].duration_s;
    // Steps small enough that the chord error is far below a centimetre.
    const int steps = std::max(8, static_cast<int>(std::ceil(duration * 100)));
    Eigen::Vector3d previous = trajectory.EvaluatePiece(i, 0, 0).head<3>();
    for (int k = 1; k <= steps; ++k) {
      const Eigen::Vector3d next = trajectory.EvaluatePiece(i, duration * k / steps, 0).head<3>();
      length += (next - previous).norm();
      previous = next;
    }
  }
  return length;
}

}  // namespace strata
