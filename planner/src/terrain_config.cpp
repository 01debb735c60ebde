#include "strata/terrain_config.hpp"

#include "format_internal.hpp"

#include <cmath>
#include <numbers>
#include <string>

namespace strata {
namespace {

Status Bad(const std::string& field, double value, const std::string& range) {
  return internal::OutOfRange(field, value, range);
}

bool InOpen(double v, double lo, double hi) { return std::isfinite(v) && v > lo && v < hi; }

}  // namespace

Status GroundFilterConfig::Validate() const {
  if (!InOpen(radius_m, 0.0, 100.0)) return Bad("ground.radius_m", radius_m, "in (0, 100) m");
  if (!InOpen(max_tilt_rad, 0.0, std::numbers::pi / 2)) {
    return Bad("ground.max_tilt_rad", max_tilt_rad, "in (0, pi/2) rad");
  }
  if (!(std::isfinite(height_tolerance_m) && height_tolerance_m >= 0 && height_tolerance_m < 1)) {
    return Bad("ground.height_tolerance_m", height_tolerance_m, "in [0, 1) m");
  }
  return Status::Ok();
}

Status GridConfig::Validate() const {
  if (!(std::isfinite(resolution_m) && resolution_m >= 0.02 && resolution_m <= 5.0)) {
    return Bad("grid.resolution_m", resolution_m, "in [0.02, 5] m");
  }
  if (!(std::isfinite(padding_m) && padding_m >= 0.0 && padding_m <= 100.0)) {
    return Bad("grid.padding_m", padding_m, "in [0, 100] m");
  }
  if (max_cells <= 0) return Bad("grid.max_cells", static_cast<double>(max_cells), "> 0");
  return Status::Ok();
}

Status FieldConfig::Validate() const {
  if (!(std::isfinite(weight_tilt) && weight_tilt >= 0)) {
    return Bad("field.weight_tilt", weight_tilt, ">= 0");
  }
  if (!(std::isfinite(weight_pose_change) && weight_pose_change >= 0)) {
    return Bad("field.weight_pose_change", weight_pose_change, ">= 0");
  }
  if (!(std::isfinite(diffusion_distance_m) && diffusion_distance_m >= 0 &&
        diffusion_distance_m <= 10)) {
    return Bad("field.diffusion_distance_m", diffusion_distance_m, "in [0, 10] m");
  }
  if (!InOpen(plane_fit_radius_m, 0.0, 10.0)) {
    return Bad("field.plane_fit_radius_m", plane_fit_radius_m, "in (0, 10) m");
  }
  if (!InOpen(plane_fit_half_height_m, 0.0, 10.0)) {
    return Bad("field.plane_fit_half_height_m", plane_fit_half_height_m, "in (0, 10) m");
  }
  if (!InOpen(plane_inlier_distance_m, 0.0, 10.0)) {
    return Bad("field.plane_inlier_distance_m", plane_inlier_distance_m, "in (0, 10) m");
  }
  if (plane_ransac_iterations < 1 || plane_ransac_iterations > 100000) {
    return Bad("field.plane_ransac_iterations", plane_ransac_iterations, "in [1, 100000]");
  }
  if (!InOpen(max_pose_gradient_per_m, 0.0, 1e6)) {
    return Bad("field.max_pose_gradient_per_m", max_pose_gradient_per_m, "in (0, 1e6) 1/m");
  }
  return Status::Ok();
}

double FieldConfig::VoidPenalty() const {
  const double half_pi = std::numbers::pi / 2;
  return weight_tilt * half_pi * half_pi + weight_pose_change * std::sqrt(max_pose_gradient_per_m);
}

Status AssessmentConfig::Validate() const {
  if (Status s = ground.Validate(); !s) return s;
  if (Status s = grid.Validate(); !s) return s;
  if (Status s = field.Validate(); !s) return s;
  if (num_threads < 0 || num_threads > 1024) {
    return Bad("num_threads", num_threads, "in [0, 1024] (0 = every core)");
  }
  return Status::Ok();
}

}  // namespace strata
