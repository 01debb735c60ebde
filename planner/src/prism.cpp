#include "strata/prism.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"

namespace strata {
namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// True when the closed segments ab and cd share a point.
bool SegmentsIntersect(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d) {
  const auto side = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                       const Eigen::Vector2d& r) {
    const double v = Cross(q - p, r - p);
    return (v > 0) - (v < 0);
  };
  const auto on_segment = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                             const Eigen::Vector2d& r) {  // r collinear with pq.
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  const int d1 = side(c, d, a), d2 = side(c, d, b), d3 = side(a, b, c), d4 = side(a, b, d);
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) ||
         (d3 == 0 && on_segment(a, b, c)) || (d4 == 0 && on_segment(a, b, d));
}

}  // namespace

Status Prism::Validate(std::string_view path) const {
  const std::string polygon_path = internal::FieldPath(path, "polygon_m");
  const int n = static_cast<int>(polygon_m.size());
  if (n < 3 || n > kMaxPrismVertices) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("{} has {} corners: give 3 to {}", polygon_path, n, kMaxPrismVertices),
                 polygon_path};
  }
  for (int i = 0; i < n; ++i) {
    for (int axis = 0; axis < 2; ++axis) {
      if (std::isfinite(polygon_m[i](axis))) continue;
      const std::string field =
          polygon_path + "[" + std::to_string(i) + "]." + (axis == 0 ? "x" : "y");
      return Error{ErrorCode::kInvalidInput, field + " must be finite", field};
    }
  }
  double twice_area = 0;
  for (int i = 0; i < n; ++i) twice_area += Cross(polygon_m[i], polygon_m[(i + 1) % n]);
  if (!(std::abs(twice_area) > 1e-6)) {
    return Error{ErrorCode::kInvalidInput,
                 polygon_path + " encloses no area: give corners that are not all on one line",
                 polygon_path};
  }
  // Non-adjacent edges must not touch: O(n^2) is at most 32k tests.
  for (int i = 0; i < n; ++i) {
    for (int j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // Adjacent through the closing edge.
      if (SegmentsIntersect(polygon_m[i], polygon_m[(i + 1) % n], polygon_m[j],
                            polygon_m[(j + 1) % n])) {
        return Error{ErrorCode::kInvalidInput,
                     fmt::format("{}: edge {} crosses edge {}; give the corners in order around "
                                 "the polygon",
                                 polygon_path, i, j),
                     polygon_path};
      }
    }
  }
  if (!std::isfinite(z_min_m)) {
    const std::string field = internal::FieldPath(path, "z_min_m");
    return Error{ErrorCode::kInvalidInput, field + " must be finite", field};
  }
  if (!(std::isfinite(z_max_m) && z_max_m >= z_min_m)) {
    const std::string field = internal::FieldPath(path, "z_max_m");
    return Error{
        ErrorCode::kInvalidInput,
        fmt::format("{} = {:g} must be finite and >= z_min_m = {:g}", field, z_max_m, z_min_m),
        field};
  }
  return Status::Ok();
}

bool Prism::ContainsXY(const Eigen::Vector2d& p) const {
  // Crossing number, with points on an edge counted inside.
  bool inside = false;
  const std::size_t n = polygon_m.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = polygon_m[j];
    const Eigen::Vector2d& b = polygon_m[i];
    if (std::abs(Cross(b - a, p - a)) <= 1e-12 * (b - a).squaredNorm() && (p - a).dot(p - b) <= 0) {
      return true;
    }
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y())) {
      inside = !inside;
    }
  }
  return inside;
}

bool Prism::Contains(const Eigen::Vector3d& p) const {
  return p.z() >= z_min_m && p.z() <= z_max_m && ContainsXY(p.head<2>());
}

double Prism::SignedDistanceXY(const Eigen::Vector2d& p, Eigen::Vector2d* gradient) const {
  double best_sq = std::numeric_limits<double>::infinity();
  Eigen::Vector2d nearest = polygon_m.front();
  const std::size_t n = polygon_m.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = polygon_m[i];
    const Eigen::Vector2d ab = polygon_m[(i + 1) % n] - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const Eigen::Vector2d q = a + t * ab;
    if (const double d_sq = (p - q).squaredNorm(); d_sq < best_sq) {
      best_sq = d_sq;
      nearest = q;
    }
  }
  const double sign = ContainsXY(p) ? -1.0 : 1.0;
  const double distance = std::sqrt(best_sq);
  if (gradient != nullptr) {
    *gradient =
        distance > 0 ? Eigen::Vector2d(sign * (p - nearest) / distance) : Eigen::Vector2d::Zero();
  }
  return sign * distance;
}

Eigen::AlignedBox3d Prism::Bounds() const {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector2d& c : polygon_m) {
    box.extend(Eigen::Vector3d(c.x(), c.y(), z_min_m));
    box.extend(Eigen::Vector3d(c.x(), c.y(), z_max_m));
  }
  return box;
}

Prism BoxPrism(const Eigen::AlignedBox3d& box_m) {
  const Eigen::Vector3d& lo = box_m.min();
  const Eigen::Vector3d& hi = box_m.max();
  return Prism{
      {{lo.x(), lo.y()}, {hi.x(), lo.y()}, {hi.x(), hi.y()}, {lo.x(), hi.y()}}, lo.z(), hi.z()};
}

}  // namespace strata
