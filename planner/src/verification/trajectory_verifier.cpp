#include "strata/verification/trajectory_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include "format_internal.hpp"
#include "strata/planning/terrain_query.hpp"

namespace strata {
namespace {

// "at t = 12.34 s, (x, y, z): <what>".
Error Violation(double t, const Eigen::Vector3d& p, const std::string& what) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "at t = %.3f s, ", t);
  return Error{ErrorCode::kOptimizationFailed, "trajectory verification failed " +
                                                   std::string(buf) + internal::FormatPoint(p) +
                                                   ": " + what};
}

std::string Exceeds(const char* quantity, double value, double bound, const char* unit) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%s %.4g %s exceeds the bound %.4g %s", quantity, value, unit,
                bound, unit);
  return buf;
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

Status VerifyTrajectory(const SurfaceGraph& graph, const RobotProfile& profile,
                        const Trajectory& trajectory, const VerifierConfig& config,
                        VerificationReport* report, std::span<const KeepOutZone> keep_out) {
  if (Status s = config.Validate(); !s) return s;
  if (Status s = profile.Validate(); !s) return s;
  const TerrainModel& model = graph.model();
  *report = VerificationReport{};
  report->min_obstacle_distance_m = std::numeric_limits<double>::infinity();
  report->min_body_height_m = std::numeric_limits<double>::infinity();
  report->min_headroom_m = std::numeric_limits<double>::infinity();
  const int dimension = profile.active_height ? 4 : 3;
  if (trajectory.dimension != dimension) {
    char buf[160];
    std::snprintf(buf, sizeof(buf),
                  "trajectory has dimension %d but profile '%s' needs %d (x, y, z%s)",
                  trajectory.dimension, profile.name.c_str(), dimension,
                  profile.active_height ? ", body height" : "");
    return Error{ErrorCode::kInvalidInput, buf};
  }
  if (trajectory.pieces.empty()) {
    return Error{ErrorCode::kOptimizationFailed, "trajectory verification failed: no pieces"};
  }
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[i];
    if (piece.coefficients.cols() != dimension) {
      return Error{ErrorCode::kInvalidInput, "trajectory piece " + std::to_string(i) + " has " +
                                                 std::to_string(piece.coefficients.cols()) +
                                                 " axes, the trajectory " +
                                                 std::to_string(dimension)};
    }
    // Everything below evaluates these; a NaN would also make the step count undefined.
    if (!(std::isfinite(piece.duration_s) && piece.duration_s > 0) ||
        !piece.coefficients.allFinite()) {
      char buf[160];
      std::snprintf(buf, sizeof(buf),
                    "trajectory verification failed: piece %zu has duration %g s and %s "
                    "coefficients; both must be finite, the duration > 0",
                    i, piece.duration_s, piece.coefficients.allFinite() ? "finite" : "non-finite");
      return Error{ErrorCode::kOptimizationFailed, buf};
    }
  }
  // Speed is at most ~1.1× the coarse peak between coarse samples of a quintic (and the 1%
  // limit check bounds it anyway), so this step keeps consecutive samples <= the spacing.
  const double peak_speed = 1.1 * PeakSpeed(trajectory);
  const double sample_count = peak_speed * trajectory.TotalDuration() / config.max_sample_spacing_m;
  if (!(sample_count <= kMaxSamples)) {
    char buf[160];
    std::snprintf(buf, sizeof(buf),
                  "trajectory verification failed: %.3g samples %.3g m apart are too many "
                  "(at most %.0f); the trajectory is too long or too fast",
                  sample_count, config.max_sample_spacing_m, kMaxSamples);
    return Error{ErrorCode::kOptimizationFailed, buf};
  }
  const double tolerance = 1 + config.limit_tolerance;
  const double body_slack_m = BodyHeightTolerance(profile, config);
  // A voxelised cloud knows its ground only to within half a quantum; the check allows that
  // plus a quarter quantum of tracking, or every staircase ramp would fail it by noise.
  const double ground_tolerance_m =
      std::max(config.ground_tolerance_m, 0.75 * model.summary().vertical_quantum_m);
  const GridGeometry& grid = graph.grid();
  // How far the plane-fit ground at the centre of the robot's own column may lie from its
  // feet: the ground tolerance plus the rise from the centre to a corner of the column on the
  // steepest slope the robot may stand on.
  const double level_tolerance_m =
      ground_tolerance_m + grid.resolution_m / std::sqrt(2.0) * std::tan(profile.max_tilt_rad);
  const Eigen::Vector3d grid_max = grid.origin_m + grid.size.cast<double>() * grid.resolution_m;

  // Consecutive samples, 2 cm apart, mostly stand on the same column corners: SampleGround
  // reuses their choice where it holds (the same answers, fewer column scans).
  GroundChoice ground_choice;
  // The checks of one state at time t, in the documented order. Every comparison is written
  // !(value within bound), so a NaN fails it.
  const auto check = [&](double t, const StateVector& pos, const StateVector& vel,
                         const StateVector& acc) -> Status {
    const Eigen::Vector3d p = pos.head<3>();
    ++report->samples;

    const double speed_h = vel.head<2>().norm(), speed_v = std::abs(vel(2));
    const double accel_h = acc.head<2>().norm(), accel_v = std::abs(acc(2));
    report->max_speed_horizontal_mps = std::max(report->max_speed_horizontal_mps, speed_h);
    report->max_speed_vertical_mps = std::max(report->max_speed_vertical_mps, speed_v);
    report->max_accel_horizontal_mps2 = std::max(report->max_accel_horizontal_mps2, accel_h);
    report->max_accel_vertical_mps2 = std::max(report->max_accel_vertical_mps2, accel_v);
    if (!(speed_h <= tolerance * profile.max_speed_horizontal_mps)) {
      return Violation(
          t, p, Exceeds("horizontal speed", speed_h, profile.max_speed_horizontal_mps, "m/s"));
    }
    if (!(speed_v <= tolerance * profile.max_speed_vertical_mps)) {
      return Violation(t, p,
                       Exceeds("vertical speed", speed_v, profile.max_speed_vertical_mps, "m/s"));
    }
    if (!(accel_h <= tolerance * profile.max_accel_horizontal_mps2)) {
      return Violation(
          t, p,
          Exceeds("horizontal acceleration", accel_h, profile.max_accel_horizontal_mps2, "m/s^2"));
    }
    if (!(accel_v <= tolerance * profile.max_accel_vertical_mps2)) {
      return Violation(
          t, p,
          Exceeds("vertical acceleration", accel_v, profile.max_accel_vertical_mps2, "m/s^2"));
    }

    // Ground: the surface the robot stands on is the one of its own column nearest to its
    // feet (SampleGround), never another level of that column (the deck above a passage
    // too low for it). It must be valid ground, not too steep, and a node of the graph.
    if (!((p.array() >= grid.origin_m.array()).all() && (p.array() < grid_max.array()).all())) {
      return Violation(t, p, "no ground: the reference point is outside the map's grid");
    }
    GroundSample ground;
    const Eigen::Vector3i cell = grid.CellOf(p);
    if (!SampleGround(model, p, profile.reference_height_m, 0, &ground, &ground_choice) ||
        SurfaceOfColumn(model, cell, ground.surface) == nullptr) {
      return Violation(t, p, "no ground in the column below the reference point");
    }
    const ColumnSurface& surface = *ground.surface;
    // The column's nearest surface may be another level: the top of a post, a table leg or
    // a wall the reference point is inside of, while the smoothed ground comes from the
    // columns around.
    const double feet_m = p.z() - profile.reference_height_m;
    if (!(std::abs(surface.plane_center_z_m - feet_m) <= level_tolerance_m)) {
      char buf[256];
      std::snprintf(buf, sizeof(buf),
                    "no ground in the column below at the robot's level: its nearest surface "
                    "is %.3f m from the reference point's ground height %.3f m (more than "
                    "%.3f m; a post, a table leg or a wall?)",
                    surface.plane_center_z_m - feet_m, feet_m, level_tolerance_m);
      return Violation(t, p, buf);
    }
    if (!surface.valid) {
      return Violation(t, p,
                       "the ground below is not valid ground (the Valid Ground Filter found "
                       "an obstacle, an overhang or a steep rise within its radius)");
    }
    const double tilt = surface.tilt_rad;
    report->max_tilt_rad = std::max(report->max_tilt_rad, tilt);
    if (!(tilt <= profile.max_tilt_rad)) {
      return Violation(
          t, p, Exceeds("ground tilt", tilt / kDegree, profile.max_tilt_rad / kDegree, "deg"));
    }
    const double offset = p.z() - ground.height_m - profile.reference_height_m;
    report->max_ground_offset_m = std::max(report->max_ground_offset_m, std::abs(offset));
    if (!(std::abs(offset) <= ground_tolerance_m)) {
      return Violation(t, p,
                       Exceeds("distance from the reference height above ground", std::abs(offset),
                               ground_tolerance_m, "m"));
    }
    const double distance = model.Distance(p);
    report->min_obstacle_distance_m = std::min(report->min_obstacle_distance_m, distance);
    if (!(distance >= config.min_obstacle_distance_m)) {
      char buf[128];
      std::snprintf(buf, sizeof(buf), "obstacle distance %.3f m is below %.3f m", distance,
                    config.min_obstacle_distance_m);
      return Violation(t, p, buf);
    }

    // Body: under the ceiling with the profile's headroom above it, within its range.
    const double body = profile.active_height ? pos(3) : profile.body_height_m;
    const double clearance = surface.clearance_m;
    report->min_body_height_m = std::min(report->min_body_height_m, body);
    report->min_headroom_m = std::min(report->min_headroom_m, clearance - body);
    if (!(body + profile.headroom_m <= clearance + body_slack_m)) {
      char buf[192];
      std::snprintf(buf, sizeof(buf),
                    "headroom %.3f m between the body (height %.3f m) and the ceiling (%.3f m "
                    "above ground) is below the profile's headroom_m %.3f m",
                    clearance - body, body, clearance, profile.headroom_m);
      return Violation(t, p, buf);
    }
    if (profile.active_height && !(body <= profile.body_height_max_m + body_slack_m &&
                                   body >= profile.body_height_min_m - body_slack_m)) {
      char buf[128];
      std::snprintf(buf, sizeof(buf), "body height %.3f m is outside [%.3f, %.3f] m", body,
                    profile.body_height_min_m, profile.body_height_max_m);
      return Violation(t, p, buf);
    }

    // The graph the path was searched on must hold this surface too (it does when it was
    // built from profile.Traversability(); another robot's graph may not).
    if (!HasNodeOn(graph, cell, ground.surface)) {
      return Violation(t, p,
                       "the ground below is not a node of the traversability graph (a graph "
                       "built for other traversability parameters than this profile's?)");
    }

    if (const int zone = FirstViolatedKeepOut(keep_out, profile, p); zone >= 0) {
      char buf[160];
      std::snprintf(buf, sizeof(buf),
                    ": the footprint (radius %.3f m) reaches %.3f m into its polygon within its "
                    "height range",
                    profile.footprint_radius_m,
                    KeepOutPenetration(keep_out[zone].prism, profile, p));
      return Violation(t, p, "inside " + keep_out[zone].name + buf);
    }
    return Status::Ok();
  };
  // Between samples (the column entries below) the cursor finds the piece from the last one.
  TrajectoryCursor cursor(trajectory);
  // The column of the reference point at global time t (floored cell coordinates, as doubles
  // so that no cast can overflow).
  const auto column_at = [&](double t) -> Eigen::Vector2d {
    const Eigen::Vector2d p = cursor.Position(t).head<2>();
    return ((p - grid.origin_m.head<2>()) / grid.resolution_m).array().floor();
  };

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
      // A ceiling, the ground's validity and the graph's nodes change at column edges, not
      // between samples: where the reference point changed columns since the last sample,
      // the state at its first instant in each column entered (bisection to 1e-9 s) is
      // checked too.
      if (previous_t >= 0) {
        const Eigen::Vector2d target = column_at(t);
        double from = previous_t;
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
          double lo = from, hi = t;
          for (int halving = 0; halving < 60 && hi - lo > 1e-9; ++halving) {
            const double mid = 0.5 * (lo + hi);
            (in_column(mid) ? lo : hi) = mid;
          }
          if (Status s =
                  check(hi, cursor.Position(hi), cursor.Velocity(hi), cursor.Acceleration(hi));
              !s) {
            return s;
          }
          from = hi;
          column = column_at(hi);
        }
      }
      if (Status s = check(t, trajectory.EvaluatePiece(i, local_t, 0),
                           trajectory.EvaluatePiece(i, local_t, 1),
                           trajectory.EvaluatePiece(i, local_t, 2));
          !s) {
        return s;
      }
      previous_t = t;
    }
    piece_start += piece_duration;
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
