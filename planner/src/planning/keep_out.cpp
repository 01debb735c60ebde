#include "strata/planning/keep_out.hpp"

#include <algorithm>
#include <utility>

namespace strata {
namespace {

// The robot's height range relative to its reference point: from its ground up to its top.
double ExtentBelow(const RobotProfile& profile) { return profile.reference_height_m; }
double ExtentAbove(const RobotProfile& profile) {
  return std::max(profile.MaxBodyHeight(), profile.reference_height_m) - profile.reference_height_m;
}

}  // namespace

KeepOutZone::KeepOutZone(Prism prism_in, std::string name_in)
    : prism(std::move(prism_in)), name(std::move(name_in)), bounds_m(prism.Bounds()) {}

double KeepOutVerticalOverlap(const Prism& zone, const RobotProfile& profile, double z_m,
                              double* derivative) {
  const double bottom = z_m - ExtentBelow(profile);
  const double top = z_m + ExtentAbove(profile);
  // min(top, z_max) rises with z while the top is below the zone's; max(bottom, z_min) while
  // the bottom is above the zone's.
  if (derivative != nullptr) {
    *derivative = (top < zone.z_max_m ? 1.0 : 0.0) - (bottom > zone.z_min_m ? 1.0 : 0.0);
  }
  return std::min(top, zone.z_max_m) - std::max(bottom, zone.z_min_m);
}

double KeepOutPenetration(const Prism& zone, const RobotProfile& profile,
                          const Eigen::Vector3d& p_m) {
  return profile.footprint_radius_m - zone.SignedDistanceXY(p_m.head<2>());
}

bool ViolatesKeepOut(const Prism& zone, const RobotProfile& profile, const Eigen::Vector3d& p_m) {
  return KeepOutVerticalOverlap(zone, profile, p_m.z()) > 0 &&
         KeepOutPenetration(zone, profile, p_m) > 0;
}

int FirstViolatedKeepOut(std::span<const KeepOutZone> zones, const RobotProfile& profile,
                         const Eigen::Vector3d& p_m) {
  const double radius = profile.footprint_radius_m;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const KeepOutZone& zone = zones[i];
    // Beyond the footprint radius of the bounds, the polygon is out of reach.
    const Eigen::Vector2d lo = zone.bounds_m.min().head<2>().array() - radius;
    const Eigen::Vector2d hi = zone.bounds_m.max().head<2>().array() + radius;
    if ((p_m.head<2>().array() < lo.array()).any() || (p_m.head<2>().array() > hi.array()).any()) {
      continue;
    }
    if (ViolatesKeepOut(zone.prism, profile, p_m)) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace strata
