#include "strata/assessment/terrain_config.hpp"

#include "format_internal.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace strata {
namespace {

Status Bad(std::string_view path, const char* name, double value, const std::string& range) {
  return internal::OutOfRange(internal::FieldPath(path, name), value, range);
}

bool InOpen(double v, double lo, double hi) { return std::isfinite(v) && v > lo && v < hi; }

}  // namespace

Status GroundFilterConfig::Validate(std::string_view path) const {
  if (!InOpen(radius_m, 0.0, 100.0)) return Bad(path, "radius_m", radius_m, "in (0, 100) m");
  if (!InOpen(max_tilt_rad, 0.0, std::numbers::pi / 2)) {
    return Bad(path, "max_tilt_rad", max_tilt_rad, "in (0, pi/2) rad");
  }
  if (!(std::isfinite(height_tolerance_m) && height_tolerance_m >= 0 && height_tolerance_m < 1)) {
    return Bad(path, "height_tolerance_m", height_tolerance_m, "in [0, 1) m");
  }
  return Status::Ok();
}

Status GridConfig::Validate(std::string_view path) const {
  if (!(std::isfinite(resolution_m) && resolution_m >= 0.02 && resolution_m <= 5.0)) {
    return Bad(path, "resolution_m", resolution_m, "in [0.02, 5] m");
  }
  if (!(std::isfinite(padding_m) && padding_m >= 0.0 && padding_m <= 100.0)) {
    return Bad(path, "padding_m", padding_m, "in [0, 100] m");
  }
  if (!(std::isfinite(band_height_m) && band_height_m > 0.0 && band_height_m <= 100.0)) {
    return Bad(path, "band_height_m", band_height_m, "in (0, 100] m");
  }
  if (!(std::isfinite(distance_cap_m) && distance_cap_m > 0.0 && distance_cap_m <= 32.0)) {
    return Bad(path, "distance_cap_m", distance_cap_m, "in (0, 32] m");
  }
  if (max_columns <= 0) return Bad(path, "max_columns", static_cast<double>(max_columns), "> 0");
  return Status::Ok();
}

Status FieldConfig::Validate(std::string_view path) const {
  if (!(std::isfinite(weight_tilt) && weight_tilt >= 0)) {
    return Bad(path, "weight_tilt", weight_tilt, ">= 0");
  }
  if (!(std::isfinite(weight_pose_change) && weight_pose_change >= 0)) {
    return Bad(path, "weight_pose_change", weight_pose_change, ">= 0");
  }
  if (!(std::isfinite(diffusion_distance_m) && diffusion_distance_m >= 0 &&
        diffusion_distance_m <= 10)) {
    return Bad(path, "diffusion_distance_m", diffusion_distance_m, "in [0, 10] m");
  }
  if (!InOpen(plane_fit_radius_m, 0.0, 10.0)) {
    return Bad(path, "plane_fit_radius_m", plane_fit_radius_m, "in (0, 10) m");
  }
  if (!InOpen(plane_fit_half_height_m, 0.0, 10.0)) {
    return Bad(path, "plane_fit_half_height_m", plane_fit_half_height_m, "in (0, 10) m");
  }
  if (!InOpen(plane_inlier_distance_m, 0.0, 10.0)) {
    return Bad(path, "plane_inlier_distance_m", plane_inlier_distance_m, "in (0, 10) m");
  }
  if (plane_ransac_iterations < 1 || plane_ransac_iterations > 100000) {
    return Bad(path, "plane_ransac_iterations", plane_ransac_iterations, "in [1, 100000]");
  }
  if (!InOpen(max_pose_gradient_per_m, 0.0, 1e6)) {
    return Bad(path, "max_pose_gradient_per_m", max_pose_gradient_per_m, "in (0, 1e6) 1/m");
  }
  return Status::Ok();
}

double FieldConfig::VoidPenalty() const {
  const double half_pi = std::numbers::pi / 2;
  return weight_tilt * half_pi * half_pi + weight_pose_change * std::sqrt(max_pose_gradient_per_m);
}

Status AssessmentConfig::Validate(std::string_view path) const {
  if (Status s = ground.Validate(internal::FieldPath(path, "ground")); !s) return s;
  if (Status s = grid.Validate(internal::FieldPath(path, "grid")); !s) return s;
  if (Status s = field.Validate(internal::FieldPath(path, "field")); !s) return s;
  if (num_threads < 0 || num_threads > 1024) {
    return Bad(path, "num_threads", num_threads, "in [0, 1024] (0 = every core)");
  }
  return Status::Ok();
}

std::optional<std::string> FirstDifference(const AssessmentConfig& a, const AssessmentConfig& b) {
  std::vector<std::pair<std::string, double>> values;
  ForEachField(a, [&](const char* name, const auto& value) {
    values.emplace_back(name, static_cast<double>(value));
  });
  std::size_t i = 0;
  std::optional<std::string> first;
  ForEachField(b, [&](const char* name, const auto& value) {
    const auto& [a_name, a_value] = values[i++];
    if (!first && a_name != "num_threads" && a_value != static_cast<double>(value)) first = name;
  });
  return first;
}

Status CheckSavedModelParameters(const AssessmentConfig& asked, const AssessmentConfig& saved,
                                 std::string_view model) {
  const std::optional<std::string> field = FirstDifference(asked, saved);
  if (!field) return Status::Ok();
  return Error{ErrorCode::kInvalidConfig,
               fmt::format("{} is a saved model, assessed with other terrain parameters (its {} "
                           "differs): ask for none, or assess its point cloud instead",
                           model, *field),
               *field};
}

}  // namespace strata
