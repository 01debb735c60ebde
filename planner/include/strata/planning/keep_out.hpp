#pragma once
/// Keep-out zones: prisms no part of the robot may enter (a closed aisle, a work area, where
/// another robot is parked). A plan honours the zones of its map (PlanningMap) and those of
/// its request (PlanRequest::keep_out); this file holds the one definition of when a robot
/// state violates a zone, used alike by Plan's start and goal check, the search, the
/// optimiser's penalty and the verifier.
///
/// The robot is a vertical cylinder around its reference point p (x, y, z): radius
/// RobotProfile::footprint_radius_m, from its ground, z − reference_height_m, up to its top,
/// that ground + max(MaxBodyHeight(), reference_height_m). A state violates a zone when
/// - horizontally, the footprint disc reaches the polygon: the signed distance from p's x, y to
///   the polygon (Prism::SignedDistanceXY, negative inside) is below footprint_radius_m; and
/// - vertically, the cylinder's height range overlaps the zone's [z_min_m, z_max_m] by more
///   than zero (ranges that only touch do not overlap).
/// The height test is what lets a zone on one storey of a garage leave the deck above and
/// the floor below free: a zone drawn from its storey's floor to below the next deck's top
/// never meets a robot standing on that deck. The cylinder reaches the highest body an
/// active-height robot can take, whatever it commands: the search knows no body height, and
/// a zone is a place to stay out of, not to crouch under.
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/planning/robot_profile.hpp"
#include "strata/prism.hpp"

namespace strata {

/// Most keep-out zones one plan request may carry: a handful of parked robots and closed
/// areas at a time. Each constraint point of the optimiser and each verified sample is checked
/// against every zone whose bounds it is near, so the count bounds a request's cost.
inline constexpr int kMaxRequestKeepOutZones = 64;

/// A zone, its name in messages ("keep-out zone keep_out[2]", "the map's keep-out zone 0"), and
/// its bounds, kept so that states far from it are dismissed in constant time.
struct KeepOutZone {
  /// `prism` must be valid (Prism::Validate).
  KeepOutZone(Prism prism, std::string name);
  Prism prism;
  std::string name;
  Eigen::AlignedBox3d bounds_m;  ///< prism.Bounds().
};

/// The robot's vertical extent above (and below) its reference point, as the file comment
/// defines it, and the vertical overlap of that extent with `zone` at reference height z_m
/// [m]: positive when they overlap, else minus the gap between them. When `derivative` is
/// given, d(overlap)/d(z_m) [-] (−1, 0 or 1; piecewise linear) is written there.
double KeepOutVerticalOverlap(const Prism& zone, const RobotProfile& profile, double z_m,
                              double* derivative = nullptr);

/// How far a state at reference point `p_m` is into `zone` horizontally [m]:
/// footprint_radius_m − SignedDistanceXY; positive when the footprint reaches the polygon.
double KeepOutPenetration(const Prism& zone, const RobotProfile& profile,
                          const Eigen::Vector3d& p_m);

/// Whether the state at reference point `p_m` violates `zone` (the file comment's definition).
bool ViolatesKeepOut(const Prism& zone, const RobotProfile& profile, const Eigen::Vector3d& p_m);

/// The index of the first zone of `zones` the state at `p_m` violates, or -1. Zones whose
/// bounds are farther than the footprint radius, or outside the robot's height range, cost
/// a few comparisons.
int FirstViolatedKeepOut(std::span<const KeepOutZone> zones, const RobotProfile& profile,
                         const Eigen::Vector3d& p_m);

}  // namespace strata
