#include "strata/assessment/safety_field.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>

namespace strata {
namespace {

// H's informative components at one projected surface. A cell that projects onto nothing is
// either inside an obstacle (within a run of occupied cells, below its top) or above a void.
struct PoseSample {
  bool defined = false;
  bool inside_obstacle = false;
  double center_z_m = 0;
  double tilt_rad = 0;
};

// The sample of a cell at layer iz of `column` (its runs, lowest first), of whose runs the
// first `passed` lie at or below iz.
PoseSample SampleOf(std::span<const ColumnSurface> column, std::size_t passed, int iz) {
  if (passed < column.size() && column[passed].bottom_layer <= iz) return {.inside_obstacle = true};
  if (passed == 0) return {};
  const ColumnSurface& below = column[passed - 1];
  return {.defined = true, .center_z_m = below.plane_center_z_m, .tilt_rad = below.tilt_rad};
}

PoseSample PoseAt(const SurfaceMap& surfaces, int ix, int iy, int iz) {
  const std::span<const ColumnSurface> column = surfaces.Column(ix, iy);
  std::size_t passed = 0;
  while (passed < column.size() && column[passed].top_layer <= iz) ++passed;
  return SampleOf(column, passed, iz);
}

// Squared derivative of (z_c, φ) along one axis from the samples before and after the cell
// (null: outside the grid). A neighbour inside an obstacle is left out like one outside the
// grid; `cap` stands in for any difference that involves a neighbour above a void.
double SquaredAxisDerivative(const PoseSample& centre, const PoseSample* before,
                             const PoseSample* after, double resolution, double cap) {
  if (before != nullptr && before->inside_obstacle) before = nullptr;
  if (after != nullptr && after->inside_obstacle) after = nullptr;
  if ((before != nullptr && !before->defined) || (after != nullptr && !after->defined)) {
    return cap * cap;
  }
  const PoseSample* lo = before != nullptr ? before : &centre;
  const PoseSample* hi = after != nullptr ? after : &centre;
  const double span = resolution * ((before != nullptr) + (after != nullptr));
  if (span == 0) return 0;
  const double dz = (hi->center_z_m - lo->center_z_m) / span;
  const double dphi = (hi->tilt_rad - lo->tilt_rad) / span;
  return dz * dz + dphi * dphi;
}

double PoseGradientFromNeighbours(const PoseSample& centre, const PoseSample* west,
                                  const PoseSample* east, const PoseSample* south,
                                  const PoseSample* north, double resolution, double cap) {
  const double squared = SquaredAxisDerivative(centre, west, east, resolution, cap) +
                         SquaredAxisDerivative(centre, south, north, resolution, cap);
  return std::min(std::sqrt(squared), cap);
}

}  // namespace

Eigen::MatrixXd ConeKernel(double diffusion_distance_m, double resolution_m) {
  if (diffusion_distance_m <= 0) return Eigen::MatrixXd::Ones(1, 1);
  const int m = 2 * static_cast<int>(std::ceil(diffusion_distance_m / resolution_m)) + 1;
  const double half = (m - 1) / 2.0;
  Eigen::MatrixXd a(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      const double dist = std::hypot(i - half, j - half);
      a(i, j) = std::max(0.0, 1.0 - resolution_m * dist / diffusion_distance_m);
    }
  }
  return a;
}

double PoseGradientNorm(const SurfaceMap& surfaces, const FieldConfig& field, int ix, int iy,
                        int iz) {
  const Eigen::Vector3i& size = surfaces.geometry().size;
  const PoseSample centre = PoseAt(surfaces, ix, iy, iz);
  PoseSample west, east, south, north;
  if (ix > 0) west = PoseAt(surfaces, ix - 1, iy, iz);
  if (ix + 1 < size.x()) east = PoseAt(surfaces, ix + 1, iy, iz);
  if (iy > 0) south = PoseAt(surfaces, ix, iy - 1, iz);
  if (iy + 1 < size.y()) north = PoseAt(surfaces, ix, iy + 1, iz);
  return PoseGradientFromNeighbours(
      centre, ix > 0 ? &west : nullptr, ix + 1 < size.x() ? &east : nullptr,
      iy > 0 ? &south : nullptr, iy + 1 < size.y() ? &north : nullptr,
      surfaces.geometry().resolution_m, field.max_pose_gradient_per_m);
}

ScalarGrid ComputeSafetyPenalty(const SurfaceMap& surfaces, const FieldConfig& field,
                                const CellBox& box) {
  const GridGeometry& g = surfaces.geometry();
  const double void_penalty = field.VoidPenalty();
  std::vector<float> values(static_cast<std::size_t>(box.CellCount()));
  if (box.empty()) return ScalarGrid(box.Geometry(g), std::move(values));
  // The layer's projections over the box and one column around it (the pose gradient's
  // neighbours), cut to the grid; a neighbour outside the grid is missing (one-sided).
  const CellBox ring = box.Grown({1, 1, 0}, g);
  const int rx = ring.size().x(), ry = ring.size().y();
  std::vector<PoseSample> layer(static_cast<std::size_t>(rx) * ry);
  // Per ring column, how many of its surfaces lie at or below the current layer: the sweep
  // upwards makes every projection O(1) amortised.
  std::vector<std::uint32_t> passed(layer.size(), 0);
  for (int y = 0; y < ry; ++y) {
    for (int x = 0; x < rx; ++x) {
      const std::span<const ColumnSurface> column =
          surfaces.Column(ring.min.x() + x, ring.min.y() + y);
      std::uint32_t k = 0;
      while (k < column.size() && column[k].top_layer < box.min.z()) ++k;
      passed[x + static_cast<std::size_t>(rx) * y] = k;
    }
  }
  const Eigen::Vector3i n = box.size();
  for (int iz = box.min.z(); iz <= box.max.z(); ++iz) {
    for (int y = 0; y < ry; ++y) {
      for (int x = 0; x < rx; ++x) {
        const std::size_t c = x + static_cast<std::size_t>(rx) * y;
        const std::span<const ColumnSurface> column =
            surfaces.Column(ring.min.x() + x, ring.min.y() + y);
        std::size_t k = passed[c];
        while (k < column.size() && column[k].top_layer <= iz) ++k;
        passed[c] = static_cast<std::uint32_t>(k);
        layer[c] = SampleOf(column, k, iz);
      }
    }
    float* out = values.data() + box.Index({box.min.x(), box.min.y(), iz});
    for (int iy = box.min.y(); iy <= box.max.y(); ++iy) {
      for (int ix = box.min.x(); ix <= box.max.x(); ++ix) {
        const int x = ix - ring.min.x(), y = iy - ring.min.y();
        const auto at = [&](int dx, int dy) {
          return &layer[(x + dx) + static_cast<std::size_t>(rx) * (y + dy)];
        };
        const PoseSample& c = *at(0, 0);
        float& value =
            out[(ix - box.min.x()) + static_cast<std::size_t>(n.x()) * (iy - box.min.y())];
        if (!c.defined) {
          value = c.inside_obstacle ? kInsideObstacle : static_cast<float>(void_penalty);
          continue;
        }
        const double grad = PoseGradientFromNeighbours(
            c, ix > 0 ? at(-1, 0) : nullptr, ix + 1 < g.size.x() ? at(1, 0) : nullptr,
            iy > 0 ? at(0, -1) : nullptr, iy + 1 < g.size.y() ? at(0, 1) : nullptr, g.resolution_m,
            field.max_pose_gradient_per_m);
        value = static_cast<float>(field.weight_tilt * c.tilt_rad * c.tilt_rad +
                                   field.weight_pose_change * std::sqrt(grad));
      }
    }
  }
  return ScalarGrid(box.Geometry(g), std::move(values));
}

SafetyDiffusion::SafetyDiffusion(const FieldConfig& field, double resolution_m)
    : void_penalty_(static_cast<float>(field.VoidPenalty())) {
  const Eigen::MatrixXd kernel = ConeKernel(field.diffusion_distance_m, resolution_m);
  reach_ = static_cast<int>(kernel.rows() / 2);
  for (int i = 0; i < kernel.rows(); ++i) {
    for (int j = 0; j < kernel.cols(); ++j) {
      if (kernel(i, j) > 0)
        taps_.push_back({i - reach_, j - reach_, static_cast<float>(kernel(i, j))});
    }
  }
}

float SafetyDiffusion::At(const ScalarGrid& penalty, const CellBox& box,
                          const Eigen::Vector3i& grid_size, const Eigen::Vector3i& cell) const {
  const Eigen::Vector3i n = box.size();
  const float* layer = penalty.values().data() + box.Index({box.min.x(), box.min.y(), cell.z()});
  const int x = cell.x() - box.min.x(), y = cell.y() - box.min.y();
  const auto value = [&](const Tap& t) {
    return layer[(x + t.dx) + static_cast<std::size_t>(n.x()) * (y + t.dy)];
  };
  // The kernel is renormalised over the cells that count: those inside the grid and not inside
  // an obstacle.
  float sum = 0, weight = 0;
  const auto add = [&](const Tap& t) {
    const float v = value(t);
    if (v == kInsideObstacle) return;
    sum += t.weight * v;
    weight += t.weight;
  };
  if (cell.x() >= reach_ && cell.x() + reach_ < grid_size.x() && cell.y() >= reach_ &&
      cell.y() + reach_ < grid_size.y()) {
    for (const Tap& t : taps_) add(t);
  } else {
    for (const Tap& t : taps_) {
      const int gx = cell.x() + t.dx, gy = cell.y() + t.dy;
      if (gx >= 0 && gx < grid_size.x() && gy >= 0 && gy < grid_size.y()) add(t);
    }
  }
  // Deep inside an obstacle, where no robot can be: unknown is unsafe.
  return weight > 0 ? sum / weight : void_penalty_;
}

ScalarGrid DiffuseSafetyPenalty(const ScalarGrid& penalty, const FieldConfig& field) {
  const GridGeometry& g = penalty.geometry();
  const SafetyDiffusion diffusion(field, g.resolution_m);
  const CellBox whole = CellBox::Whole(g);
  std::vector<float> out(penalty.values().size());
  for (int iz = 0; iz < g.size.z(); ++iz) {
    for (int iy = 0; iy < g.size.y(); ++iy) {
      for (int ix = 0; ix < g.size.x(); ++ix) {
        out[g.Index(ix, iy, iz)] = diffusion.At(penalty, whole, g.size, {ix, iy, iz});
      }
    }
  }
  return ScalarGrid(g, std::move(out));
}

}  // namespace strata
