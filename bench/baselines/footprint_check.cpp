#include "baselines/footprint_check.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numbers>

namespace strata::baselines {
namespace {

// Vertical extent of the column CheckFootprint looks at, relative to ground_m: the plane
// itself moves by up to support_radius·tanθ across the disc.
void ColumnExtent(const BaselineRobot& robot, double support_radius_m, double* low, double* high) {
  const double tilt_rise = support_radius_m * std::tan(robot.max_tilt_rad);
  *low = -robot.max_step_m - tilt_rise;
  *high = robot.clearance_m() + tilt_rise;
}

}  // namespace

double CheckFootprintQueryRadius(const BaselineRobot& robot, double support_radius_m) {
  double low, high;
  ColumnExtent(robot, support_radius_m, &low, &high);
  return std::hypot(support_radius_m, 0.5 * (high - low));
}

double CheckFootprintCenterLift(const BaselineRobot& robot, double support_radius_m) {
  double low, high;
  ColumnExtent(robot, support_radius_m, &low, &high);
  return 0.5 * (high + low);
}

FootprintVerdict CheckFootprint(const Eigen::Vector3f& ground_m, const Eigen::Vector3f& normal,
                                std::span<const Eigen::Vector3f> neighbours,
                                const BaselineRobot& robot, double support_radius_m) {
  const float body_r2 = static_cast<float>(robot.footprint_radius_m * robot.footprint_radius_m);
  const float support_r2 = static_cast<float>(support_radius_m * support_radius_m);
  const float inner_r2 = 0.36f * support_r2;  // (60% of the radius)²
  const float step = static_cast<float>(robot.max_step_m);
  const float clearance = static_cast<float>(robot.clearance_m());
  const float nz = std::max(normal.z(), 1e-3f);
  bool sector[8] = {false, false, false, false, false, false, false, false};
  FootprintVerdict verdict;
  verdict.body_free = true;
  for (const Eigen::Vector3f& q : neighbours) {
    const Eigen::Vector3f d = q - ground_m;
    const float r2 = d.x() * d.x() + d.y() * d.y();
    if (r2 > support_r2) continue;
    // Height above the plane through ground_m, measured along z.
    const float h = d.z() + (normal.x() * d.x() + normal.y() * d.y()) / nz;
    if (std::abs(h) <= step) {
      if (r2 >= inner_r2) {
        const float angle = std::atan2(d.y(), d.x()) + static_cast<float>(std::numbers::pi);
        sector[std::clamp(static_cast<int>(angle * static_cast<float>(4 / std::numbers::pi)), 0,
                          7)] = true;
      }
    } else if (h > step && h <= clearance && r2 <= body_r2) {
      verdict.body_free = false;
      return verdict;
    }
  }
  verdict.supported = std::all_of(std::begin(sector), std::end(sector), [](bool b) { return b; });
  return verdict;
}

}  // namespace strata::baselines
