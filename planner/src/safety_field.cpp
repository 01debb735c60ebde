#include "strata/safety_field.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "parallel_internal.hpp"

namespace strata {
namespace {

// H's informative components at one projected surface.
struct PoseSample {
  bool defined = false;
  double center_z_m = 0;
  double tilt_rad = 0;
};

PoseSample PoseAt(const SurfaceMap& surfaces, int ix, int iy, int iz) {
  const ColumnSurface* s = surfaces.SurfaceBelow(ix, iy, iz);
  if (s == nullptr) return {};
  return {true, s->plane_center_z_m, s->tilt_rad};
}

// Squared derivative of (z_c, φ) along one axis from the samples before and after the cell;
// `cap` stands in for any difference that involves an undefined neighbour.
double SquaredAxisDerivative(const PoseSample& centre, const PoseSample* before,
                             const PoseSample* after, double resolution, double cap) {
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
                                int num_threads) {
  num_threads = internal::ResolveThreadCount(num_threads);
  const GridGeometry& g = surfaces.geometry();
  const int nx = g.size.x();
  const int ny = g.size.y();
  const double void_penalty = field.VoidPenalty();
  std::vector<float> values(g.CellCount());

#pragma omp parallel num_threads(num_threads)
  {
    // Each thread sweeps a contiguous block of layers upwards, keeping per column how many of
    // its surfaces lie at or below the current layer, so every projection is O(1) amortised.
    std::vector<PoseSample> layer(static_cast<std::size_t>(nx) * ny);
    std::vector<std::uint32_t> passed(static_cast<std::size_t>(nx) * ny, 0);
#pragma omp for schedule(static)
    for (int iz = 0; iz < g.size.z(); ++iz) {
      for (int iy = 0; iy < ny; ++iy) {
        for (int ix = 0; ix < nx; ++ix) {
          const std::size_t c = ix + static_cast<std::size_t>(nx) * iy;
          const std::span<const ColumnSurface> column = surfaces.Column(ix, iy);
          std::size_t k = passed[c];
          while (k < column.size() && column[k].top_layer <= iz) ++k;
          passed[c] = static_cast<std::uint32_t>(k);
          const bool inside = k < column.size() && column[k].bottom_layer <= iz;
          if (k == 0 || inside) {
            layer[c] = {};
          } else {
            layer[c] = {true, column[k - 1].plane_center_z_m, column[k - 1].tilt_rad};
          }
        }
      }
      float* out = values.data() + g.Index(0, 0, iz);
      for (int iy = 0; iy < ny; ++iy) {
        for (int ix = 0; ix < nx; ++ix) {
          const PoseSample& c = layer[ix + nx * iy];
          if (!c.defined) {
            out[ix + nx * iy] = static_cast<float>(void_penalty);
            continue;
          }
          const double grad =
              PoseGradientFromNeighbours(c, ix > 0 ? &layer[ix - 1 + nx * iy] : nullptr,
                                         ix + 1 < nx ? &layer[ix + 1 + nx * iy] : nullptr,
                                         iy > 0 ? &layer[ix + nx * (iy - 1)] : nullptr,
                                         iy + 1 < ny ? &layer[ix + nx * (iy + 1)] : nullptr,
                                         g.resolution_m, field.max_pose_gradient_per_m);
          out[ix + nx * iy] = static_cast<float>(field.weight_tilt * c.tilt_rad * c.tilt_rad +
                                                 field.weight_pose_change * std::sqrt(grad));
        }
      }
    }
  }
  return ScalarGrid(g, std::move(values));
}

ScalarGrid DiffuseSafetyPenalty(const ScalarGrid& penalty, const FieldConfig& field,
                                int num_threads) {
  num_threads = internal::ResolveThreadCount(num_threads);
  const GridGeometry& g = penalty.geometry();
  const Eigen::MatrixXd kernel = ConeKernel(field.diffusion_distance_m, g.resolution_m);
  if (kernel.size() == 1) return penalty;

  struct Tap {
    int dx, dy;
    float weight;
  };
  std::vector<Tap> taps;
  const int half = static_cast<int>(kernel.rows() / 2);
  for (int i = 0; i < kernel.rows(); ++i) {
    for (int j = 0; j < kernel.cols(); ++j) {
      if (kernel(i, j) > 0) taps.push_back({i - half, j - half, static_cast<float>(kernel(i, j))});
    }
  }
  float total_weight = 0;
  for (const Tap& t : taps) total_weight += t.weight;
  const int nx = g.size.x();
  const int ny = g.size.y();
  const std::vector<float>& in = penalty.values();
  std::vector<float> out(in.size());

#pragma omp parallel for collapse(2) schedule(static) num_threads(num_threads)
  for (int iz = 0; iz < g.size.z(); ++iz) {
    for (int iy = 0; iy < ny; ++iy) {
      const float* layer = in.data() + g.Index(0, 0, iz);
      float* row = out.data() + g.Index(0, iy, iz);
      const bool interior_y = iy >= half && iy + half < ny;
      for (int ix = 0; ix < nx; ++ix) {
        float sum = 0;
        float weight = 0;
        if (interior_y && ix >= half && ix + half < nx) {
          for (const Tap& t : taps) sum += t.weight * layer[(ix + t.dx) + nx * (iy + t.dy)];
          weight = total_weight;
        } else {
          for (const Tap& t : taps) {
            const int x = ix + t.dx;
            const int y = iy + t.dy;
            if (x < 0 || x >= nx || y < 0 || y >= ny) continue;
            sum += t.weight * layer[x + nx * y];
            weight += t.weight;
          }
        }
        row[ix] = sum / weight;
      }
    }
  }
  return ScalarGrid(g, std::move(out));
}

}  // namespace strata
