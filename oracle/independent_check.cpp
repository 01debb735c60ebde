#include "independent_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace strata::bench {
namespace {

// The `order`-th time derivative (0..2) of Σ_k c_k t^k on every axis of one piece, by Horner.
Eigen::VectorXd Derivative(const TrajectoryPiece& piece, double t, int order) {
  const Eigen::Index axes = piece.coefficients.cols();
  Eigen::VectorXd value = Eigen::VectorXd::Zero(axes);
  for (int k = 5; k >= order; --k) {
    double factor = 1;  // k·(k−1)·…·(k−order+1)
    for (int m = 0; m < order; ++m) factor *= k - m;
    value = value * t + factor * piece.coefficients.row(k).transpose();
  }
  return value;
}

bool Checkable(const Trajectory& trajectory, int dimension) {
  if (trajectory.pieces.empty() || trajectory.dimension != dimension) return false;
  return std::all_of(trajectory.pieces.begin(), trajectory.pieces.end(), [&](const auto& piece) {
    return piece.coefficients.cols() == dimension && piece.coefficients.allFinite() &&
           std::isfinite(piece.duration_s) && piece.duration_s > 0;
  });
}

// The highest surface of p's column whose ground is at or below p: where p falls to.
const ColumnSurface* SurfaceBelow(const TerrainModel& model, const Eigen::Vector3d& p) {
  const GridGeometry& grid = model.grid();
  const Eigen::Vector3d local = (p - grid.origin_m) / grid.resolution_m;
  if (!(local.x() >= 0 && local.y() >= 0 && local.x() < grid.size.x() &&
        local.y() < grid.size.y())) {
    return nullptr;
  }
  const ColumnSurface* below = nullptr;
  for (const ColumnSurface& s :
       model.surfaces().Column(static_cast<int>(local.x()), static_cast<int>(local.y()))) {
    if (s.ground_z_m <= p.z()) below = &s;  // Lowest first.
  }
  return below;
}

// Horizontal distance from (x, y) to the polygon's boundary, negative inside (even-odd rule).
double SignedDistanceToPolygon(const std::vector<Eigen::Vector2d>& polygon,
                               const Eigen::Vector2d& p) {
  double nearest = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Eigen::Vector2d& a = polygon[j];
    const Eigen::Vector2d& b = polygon[i];
    const Eigen::Vector2d edge = b - a;
    const double along = std::clamp((p - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
    nearest = std::min(nearest, (a + along * edge - p).norm());
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < a.x() + (p.y() - a.y()) / (b.y() - a.y()) * edge.x()) {
      inside = !inside;
    }
  }
  return inside ? -nearest : nearest;
}

// Whether the robot at reference point p is inside `zone` (IndependentCheckConfig::keep_out).
bool InsideZone(const Prism& zone, const RobotProfile& profile, const Eigen::Vector3d& p) {
  const double ground = p.z() - profile.reference_height_m;
  const double top = ground + std::max(profile.MaxBodyHeight(), profile.reference_height_m);
  const double overlap = std::min(top, zone.z_max_m) - std::max(ground, zone.z_min_m);
  return overlap > 0 &&
         SignedDistanceToPolygon(zone.polygon_m, p.head<2>()) < profile.footprint_radius_m;
}

}  // namespace

IndependentCheckCounts CheckTrajectory(const TerrainModel& model, const RobotProfile& profile,
                                       const Trajectory& trajectory,
                                       const IndependentCheckConfig& config) {
  IndependentCheckCounts counts;
  if (!Checkable(trajectory, profile.active_height ? 4 : 3)) {
    counts.ground = counts.clearance = counts.headroom = counts.body_height = counts.speed =
        counts.acceleration = counts.keep_out = 1;
    return counts;
  }
  const IndependentCheckBounds& bounds = config.bounds;
  const double limit = 1 + bounds.limit_tolerance;
  const double body_tolerance = bounds.limit_tolerance * profile.MaxBodyHeight();
  const double ground_tolerance =
      std::max(bounds.ground_tolerance_m, 0.75 * model.summary().vertical_quantum_m) +
      model.grid().resolution_m * std::sqrt(2.0) * std::tan(profile.max_tilt_rad);

  const auto check_motion = [&](const Eigen::VectorXd& pos, const Eigen::VectorXd& vel,
                                const Eigen::VectorXd& acc) {
    ++counts.motion_samples;
    const bool fast = !(vel.head<2>().norm() <= limit * profile.max_speed_horizontal_mps &&
                        std::abs(vel(2)) <= limit * profile.max_speed_vertical_mps);
    const bool hard = !(acc.head<2>().norm() <= limit * profile.max_accel_horizontal_mps2 &&
                        std::abs(acc(2)) <= limit * profile.max_accel_vertical_mps2);
    counts.speed += fast;
    counts.acceleration += hard;
    if (profile.active_height) {
      counts.body_height += !(pos(3) <= profile.body_height_max_m + body_tolerance &&
                              pos(3) >= profile.body_height_min_m - body_tolerance);
    }
  };
  const auto check_map = [&](const Eigen::VectorXd& pos) {
    ++counts.map_samples;
    const Eigen::Vector3d p = pos.head<3>();
    const ColumnSurface* surface = SurfaceBelow(model, p);
    if (surface == nullptr) {
      ++counts.ground;
      ++counts.headroom;  // No ceiling can be judged without a ground.
    } else {
      const double offset = p.z() - profile.reference_height_m - surface->ground_z_m;
      counts.ground += !(surface->valid && surface->tilt_rad <= profile.max_tilt_rad &&
                         std::abs(offset) <= ground_tolerance);
      const double body = profile.active_height ? pos(3) : profile.body_height_m;
      counts.headroom += !(surface->clearance_m - body >= profile.headroom_m - body_tolerance);
    }
    counts.clearance += !(model.Distance(p) >= bounds.min_obstacle_distance_m);
    counts.keep_out += std::any_of(config.keep_out.begin(), config.keep_out.end(),
                                   [&](const Prism& zone) { return InsideZone(zone, profile, p); });
  };

  // Motion rules at every time step, map rules every spacing_m of arc length (and at both
  // ends), each piece stepped from its start.
  double since_map_sample_m = 0;
  Eigen::VectorXd previous;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[i];
    const int steps =
        std::max(1, static_cast<int>(std::ceil(piece.duration_s / config.time_step_s)));
    const bool last_piece = i + 1 == trajectory.pieces.size();
    for (int k = 0; k <= steps - (last_piece ? 0 : 1); ++k) {
      const double t = piece.duration_s * k / steps;
      const Eigen::VectorXd pos = Derivative(piece, t, 0);
      check_motion(pos, Derivative(piece, t, 1), Derivative(piece, t, 2));
      if (previous.size() > 0) since_map_sample_m += (pos - previous).head<3>().norm();
      previous = pos;
      const bool end = last_piece && k == steps;
      if (counts.map_samples == 0 || since_map_sample_m >= config.spacing_m || end) {
        check_map(pos);
        since_map_sample_m = std::max(0.0, since_map_sample_m - config.spacing_m);
      }
    }
  }
  return counts;
}

std::string IndependentCheckCounts::Describe() const {
  return "ground " + std::to_string(ground) + ", clearance " + std::to_string(clearance) +
         ", headroom " + std::to_string(headroom) + ", body height " + std::to_string(body_height) +
         ", speed " + std::to_string(speed) + ", acceleration " + std::to_string(acceleration) +
         ", keep-out " + std::to_string(keep_out);
}

void IndependentCheckTally::Add(const IndependentCheckCounts& counts) {
  ++plans;
  ground += counts.ground > 0;
  clearance += counts.clearance > 0;
  headroom += counts.headroom > 0;
  body_height += counts.body_height > 0;
  speed += counts.speed > 0;
  acceleration += counts.acceleration > 0;
  keep_out += counts.keep_out > 0;
}

std::string IndependentCheckTally::Describe() const {
  return std::to_string(plans) + " checked: ground " + std::to_string(ground) + ", clearance " +
         std::to_string(clearance) + ", headroom " + std::to_string(headroom) + ", body height " +
         std::to_string(body_height) + ", speed " + std::to_string(speed) + ", acceleration " +
         std::to_string(acceleration) + ", keep-out " + std::to_string(keep_out);
}

std::string IndependentCheckCsvHeader() {
  return "check_ground,check_clearance,check_headroom,check_body_height,check_speed,"
         "check_acceleration,check_keep_out";
}

std::string IndependentCheckCsvValues(const IndependentCheckCounts* c) {
  if (c == nullptr) return "-1,-1,-1,-1,-1,-1,-1";
  return std::to_string(c->ground) + ',' + std::to_string(c->clearance) + ',' +
         std::to_string(c->headroom) + ',' + std::to_string(c->body_height) + ',' +
         std::to_string(c->speed) + ',' + std::to_string(c->acceleration) + ',' +
         std::to_string(c->keep_out);
}

}  // namespace strata::bench
