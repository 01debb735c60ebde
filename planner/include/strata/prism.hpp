#pragma once
/// A vertical prism: a simple polygon in x, y extruded over a height range. The one shape of
/// map edits (an obstacle added, points removed) and of keep-out zones, on a map or in one
/// plan request.
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/status.hpp"

namespace strata {

struct Prism {
  /// Corners of a simple polygon in x, y [m], in either order, 3 to kMaxPrismVertices; the
  /// last connects back to the first.
  std::vector<Eigen::Vector2d> polygon_m;
  double z_min_m = 0;  ///< Bottom [m], finite.
  double z_max_m = 0;  ///< Top [m], finite, >= z_min_m.

  /// kInvalidInput blaming `path`.<field> (e.g. "keep_out[2].polygon_m[3].x") for a corner
  /// that is not finite, too few or too many corners, crossing edges or zero area, and
  /// z_max_m < z_min_m.
  Status Validate(std::string_view path) const;

  /// True when `p` lies inside the polygon (boundary included) and within [z_min_m, z_max_m].
  bool Contains(const Eigen::Vector3d& p) const;
  /// True when `p`'s x, y lie inside the polygon (boundary included), whatever its height.
  bool ContainsXY(const Eigen::Vector2d& p) const;
  /// Horizontal distance from `p` to the polygon's boundary, negative inside [m]; when
  /// `gradient` is given, its derivative with respect to p's x, y [-] (unit length, away from
  /// the polygon) is written there. Where two edges are equally near the gradient is either.
  double SignedDistanceXY(const Eigen::Vector2d& p, Eigen::Vector2d* gradient = nullptr) const;
  /// Bounding box [m].
  Eigen::AlignedBox3d Bounds() const;
};

/// Most corners of a Prism polygon: enough for any hand-drawn zone, few enough that the
/// checks that run per constraint point stay cheap.
inline constexpr int kMaxPrismVertices = 256;

/// The prism of an axis-aligned box.
Prism BoxPrism(const Eigen::AlignedBox3d& box_m);

}  // namespace strata
