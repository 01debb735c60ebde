#include "strata/assessment/grid.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <fmt/format.h>

namespace strata {
namespace {

// Numbers in these messages are short {:.3g}: extents and cell counts span many orders of
// magnitude.
std::string FormatBox(const Eigen::AlignedBox3d& box) {
  const Eigen::Vector3d& lo = box.min();
  const Eigen::Vector3d& hi = box.max();
  return fmt::format("[({:.3g}, {:.3g}, {:.3g}), ({:.3g}, {:.3g}, {:.3g})] m", lo.x(), lo.y(),
                     lo.z(), hi.x(), hi.y(), hi.z());
}

}  // namespace

Expected<GridGeometry> MakeGridGeometry(const Eigen::AlignedBox3d& bounds, double resolution_m,
                                        double padding_m, std::int64_t max_columns) {
  if (!std::isfinite(resolution_m) || resolution_m <= 0.0) {
    return Error{
        ErrorCode::kInvalidInput,
        fmt::format("grid resolution {:.3g} m must be a finite positive number", resolution_m)};
  }
  if (!std::isfinite(padding_m) || padding_m < 0.0) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("grid padding {:.3g} m must be finite and >= 0", padding_m)};
  }
  if (!bounds.min().allFinite() || !bounds.max().allFinite()) {
    return Error{ErrorCode::kInvalidInput,
                 "grid bounds " + FormatBox(bounds) + " are not finite; check the map's points"};
  }
  if (bounds.isEmpty()) {
    return Error{ErrorCode::kInvalidInput,
                 "grid bounds " + FormatBox(bounds) + " are empty (min > max on some axis)"};
  }

  const Eigen::Vector3d lo = bounds.min().array() - padding_m;
  const Eigen::Vector3d hi = bounds.max().array() + padding_m;
  const Eigen::Vector3d extent = hi - lo;
  // Count in double first: absurd coordinates (wrong units, a stray point at 1e7 m) would
  // overflow int before the limit check could refuse them.
  Eigen::Vector3d cells_per_axis;
  for (int a = 0; a < 3; ++a) {
    double n = std::max(1.0, std::ceil(extent[a] / resolution_m));
    // ceil of a rounded quotient can fall one cell short of hi; the grid must cover it.
    if (lo[a] + n * resolution_m < hi[a]) n += 1.0;
    cells_per_axis[a] = n;
  }
  const double column_count = cells_per_axis.x() * cells_per_axis.y();
  // Layers are bounded too: tiles stack them, and indices must stay far from overflow.
  const double max_layers = static_cast<double>(std::numeric_limits<int>::max()) / 4;
  if (column_count > static_cast<double>(max_columns) || cells_per_axis.maxCoeff() > max_layers) {
    return Error{ErrorCode::kResourceExhausted,
                 fmt::format("a {:.3g} m grid over {:.3g} × {:.3g} × {:.3g} m needs {:.3g} "
                             "columns, above the limit of {:.3g}; check the map's units or use a "
                             "coarser resolution",
                             resolution_m, extent.x(), extent.y(), extent.z(), column_count,
                             static_cast<double>(max_columns))};
  }

  GridGeometry geometry;
  geometry.origin_m = lo;
  geometry.resolution_m = resolution_m;
  geometry.size = cells_per_axis.cast<int>();
  return geometry;
}

ScalarGrid::ScalarGrid(const GridGeometry& geometry, std::vector<float> values)
    : geometry_(geometry), values_(std::move(values)) {
  assert(static_cast<std::int64_t>(values_.size()) == geometry_.CellCount());
}

double ScalarGrid::Sample(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  // Hot path of the optimiser: scalar code, no allocation, corner offsets computed directly.
  const GridGeometry& g = geometry_;
  const double inv_r = 1.0 / g.resolution_m;
  const std::int64_t stride[3] = {1, g.size.x(), g.LayerCellCount()};

  std::int64_t base = 0;
  std::int64_t step[3];
  double t[3];
  bool clamped[3];
  for (int a = 0; a < 3; ++a) {
    // u is the position in "centre coordinates": cell centre i sits at u = i.
    double u = (p[a] - g.origin_m[a]) * inv_r - 0.5;
    const int n = g.size[a];
    const double u_max = n - 1;
    clamped[a] = false;
    if (!(u >= 0.0)) {  // Also catches NaN, which would otherwise index out of range.
      u = 0.0;
      clamped[a] = true;
    } else if (u > u_max) {
      u = u_max;
      clamped[a] = true;
    }
    int i = static_cast<int>(u);
    // The last centre belongs to the cell pair (n-2, n-1) with t = 1; a one-cell axis has no
    // pair and interpolates nothing.
    if (i > n - 2) i = n > 1 ? n - 2 : 0;
    t[a] = u - i;
    step[a] = n > 1 ? stride[a] : 0;
    base += i * stride[a];
  }

  const float* v = values_.data() + base;
  const std::int64_t sx = step[0], sy = step[1], sz = step[2];
  const double v000 = v[0], v100 = v[sx], v010 = v[sy], v110 = v[sx + sy];
  const double v001 = v[sz], v101 = v[sx + sz], v011 = v[sy + sz], v111 = v[sx + sy + sz];
  const double tx = t[0], ty = t[1], tz = t[2];

  const double c00 = v000 + tx * (v100 - v000);
  const double c10 = v010 + tx * (v110 - v010);
  const double c01 = v001 + tx * (v101 - v001);
  const double c11 = v011 + tx * (v111 - v011);
  const double c0 = c00 + ty * (c10 - c00);
  const double c1 = c01 + ty * (c11 - c01);
  const double value = c0 + tz * (c1 - c0);

  if (gradient != nullptr) {
    const double dx = (1.0 - tz) * ((1.0 - ty) * (v100 - v000) + ty * (v110 - v010)) +
                      tz * ((1.0 - ty) * (v101 - v001) + ty * (v111 - v011));
    const double dy = (1.0 - tz) * (c10 - c00) + tz * (c11 - c01);
    const double dz = c1 - c0;
    *gradient = Eigen::Vector3d(clamped[0] ? 0.0 : dx * inv_r, clamped[1] ? 0.0 : dy * inv_r,
                                clamped[2] ? 0.0 : dz * inv_r);
  }
  return value;
}

GridGeometry::OffsetRange GridGeometry::OffsetsOfIndex(double index) const {
  // Division rounds monotonically, so each end is the first double on its index's side, a
  // few ulps from index·r.
  // An infinite index (a position that overflowed) has no offsets; nor, by its comparisons,
  // a NaN. Returning early also keeps the search below from stepping away from −∞ forever.
  if (!std::isfinite(index)) return {index, index};
  const double r = resolution_m;
  const auto first_reaching = [r](double value) {
    double d = value * r;
    while (d / r >= value) d = std::nextafter(d, -std::numeric_limits<double>::infinity());
    while (d / r < value) d = std::nextafter(d, std::numeric_limits<double>::infinity());
    return d;
  };
  return {first_reaching(index), first_reaching(index + 1)};
}

}  // namespace strata
