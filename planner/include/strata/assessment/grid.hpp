#pragma once
/// A regular 3D grid over the map and a dense scalar field on it with trilinear interpolation.
/// Cell (ix, iy, iz) spans [origin + i·r, origin + (i+1)·r) on each axis; values live at cell
/// centres. Storage is x-fastest, so one horizontal layer is contiguous.

#include <algorithm>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/status.hpp"

namespace strata {

/// Placement and size of the grid.
struct GridGeometry {
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();  ///< Min corner of cell (0,0,0) [m].
  double resolution_m = 0.2;                           ///< Cell edge [m], > 0.
  Eigen::Vector3i size = Eigen::Vector3i::Zero();      ///< Cells per axis [-], >= 1.

  std::int64_t CellCount() const { return std::int64_t{size.x()} * size.y() * size.z(); }
  std::int64_t LayerCellCount() const { return std::int64_t{size.x()} * size.y(); }
  std::int64_t Index(int ix, int iy, int iz) const {
    return ix + std::int64_t{size.x()} * (iy + std::int64_t{size.y()} * iz);
  }
  std::int64_t Index(const Eigen::Vector3i& c) const { return Index(c.x(), c.y(), c.z()); }
  bool Contains(const Eigen::Vector3i& c) const {
    return (c.array() >= 0).all() && (c.array() < size.array()).all();
  }
  /// The cell holding p (may lie outside the grid; check with Contains).
  Eigen::Vector3i CellOf(const Eigen::Vector3d& p) const {
    return ((p - origin_m) / resolution_m).array().floor().cast<int>();
  }
  Eigen::Vector3d CellCenter(const Eigen::Vector3i& c) const {
    return origin_m + (c.cast<double>().array() + 0.5).matrix() * resolution_m;
  }
  /// The offsets d from origin_m along an axis that CellOf puts in cell `index`, floor(d /
  /// resolution_m) = index to the bit: [low, high), empty for a non-finite index. For a loop
  /// that would otherwise divide.
  struct OffsetRange {
    double low;
    double high;
  };
  OffsetRange OffsetsOfIndex(double index) const;
};

/// The cells [min, max] of a grid, bounds included on every axis; empty when min > max on some
/// axis. Values over a box are stored x fastest, then y, then z.
struct CellBox {
  Eigen::Vector3i min = Eigen::Vector3i::Zero();
  Eigen::Vector3i max = -Eigen::Vector3i::Ones();

  /// Every cell of `geometry`.
  static CellBox Whole(const GridGeometry& geometry) {
    return {Eigen::Vector3i::Zero(), geometry.size - Eigen::Vector3i::Ones()};
  }
  bool empty() const { return (max.array() < min.array()).any(); }
  Eigen::Vector3i size() const { return (max - min + Eigen::Vector3i::Ones()).cwiseMax(0); }
  std::int64_t CellCount() const {
    const Eigen::Vector3i n = size();
    return std::int64_t{n.x()} * n.y() * n.z();
  }
  bool Contains(const Eigen::Vector3i& c) const {
    return (c.array() >= min.array()).all() && (c.array() <= max.array()).all();
  }
  /// Index of cell c (grid coordinates, inside the box) in values over the box.
  std::int64_t Index(const Eigen::Vector3i& c) const {
    const Eigen::Vector3i n = size();
    return (c.x() - min.x()) +
           std::int64_t{n.x()} * ((c.y() - min.y()) + std::int64_t{n.y()} * (c.z() - min.z()));
  }
  /// The box grown by `cells` on each axis and cut to `geometry`.
  CellBox Grown(const Eigen::Vector3i& cells, const GridGeometry& geometry) const {
    return {(min - cells).cwiseMax(0),
            (max + cells).cwiseMin(geometry.size - Eigen::Vector3i::Ones())};
  }
  /// The geometry of a grid made of the box's cells.
  GridGeometry Geometry(const GridGeometry& geometry) const {
    GridGeometry g = geometry;
    g.origin_m = geometry.origin_m + min.cast<double>() * geometry.resolution_m;
    g.size = size();
    return g;
  }
};

/// Grid rows per chunk of an assessed model's column arrays (SurfaceMap, TerrainFields): a
/// chunk holds the columns of its rows with offsets from its own start, so that the versions
/// of a map share every chunk an edit did not touch instead of copying it (docs/design.md,
/// "Map edits"). A row of a tiled model's tiles (strata/io/model_tiles.hpp) is one chunk.
inline constexpr int kChunkRows = 64;
/// The chunks of kChunkRows grid rows that cover `geometry`'s rows (the last may hold fewer).
inline int ChunkCount(const GridGeometry& geometry) {
  return (geometry.size.y() + kChunkRows - 1) / kChunkRows;
}
/// The grid rows of chunk `chunk` of `geometry`: [chunk · kChunkRows, that + the count).
inline int ChunkRowCount(const GridGeometry& geometry, int chunk) {
  return std::min(kChunkRows, geometry.size.y() - chunk * kChunkRows);
}
/// The columns of chunk `chunk` of `geometry`, over the grid's whole height.
inline CellBox ChunkColumns(const GridGeometry& geometry, int chunk) {
  return {{0, chunk * kChunkRows, 0},
          {geometry.size.x() - 1, chunk * kChunkRows + ChunkRowCount(geometry, chunk) - 1,
           geometry.size.z() - 1}};
}

/// A grid covering `bounds` grown by `padding_m` on every side. Fails with kResourceExhausted
/// when it would need more than `max_columns` columns (x × y cells; e.g. absurd coordinates)
/// or more than 2^29 cells along an axis, and with kInvalidInput for an empty box or a
/// non-positive resolution.
Expected<GridGeometry> MakeGridGeometry(const Eigen::AlignedBox3d& bounds, double resolution_m,
                                        double padding_m, std::int64_t max_columns);

/// Dense float values at cell centres, sampled by trilinear interpolation.
class ScalarGrid {
 public:
  ScalarGrid() = default;
  ScalarGrid(const GridGeometry& geometry, std::vector<float> values);

  const GridGeometry& geometry() const { return geometry_; }
  const std::vector<float>& values() const { return values_; }
  float at(int ix, int iy, int iz) const { return values_[geometry_.Index(ix, iy, iz)]; }

  /// Trilinear interpolation of the centre values at p. Outside the hull of cell centres the
  /// position is clamped onto it (the gradient's clamped components are then zero). When
  /// `gradient` is non-null it receives the exact gradient of the interpolant [unit/m].
  double Sample(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const;

  std::size_t MemoryBytes() const { return values_.capacity() * sizeof(float); }

 private:
  GridGeometry geometry_;
  std::vector<float> values_;
};

}  // namespace strata
