#pragma once
/// The surfaces of the map, column by column: the top of every run of occupied cells in a
/// vertical column of the grid, with its ground height, free clearance above, and the local
/// plane fit. This is the "downward projection" of the paper (Sec. IV) made explicit: any
/// point projects onto the highest surface below it in its column.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/point_cloud.hpp"

namespace strata {
namespace internal {
struct ColumnCloud;
class ProgressReporter;
}  // namespace internal

/// One upper surface in a column (a "level").
struct ColumnSurface {
  float ground_z_m = 0;           ///< Height of the ground: highest valid point in the top cell
                                  ///< (highest point if none is valid) [m].
  float clearance_m = 0;          ///< Free height from ground_z_m to the next obstacle above in
                                  ///< the column; +infinity when nothing is above [m].
  float tilt_rad = 0;             ///< φ of the local plane fit [rad], in [0, π/2].
  float plane_center_z_m = 0;     ///< Height of the local plane above the column centre, p_c [m].
  std::int32_t top_layer = 0;     ///< Grid layer of the run's top cell.
  std::int32_t bottom_layer = 0;  ///< Grid layer of the run's bottom cell.
  bool valid = false;             ///< The top cell holds Valid-Ground-Filter points.
};

/// The surfaces of some columns: `column_begin` holds one offset into `surfaces` per column
/// (x fastest) plus the total, each column's surfaces lowest first.
struct ColumnSurfaces {
  std::vector<std::uint32_t> column_begin;
  std::vector<ColumnSurface> surfaces;
};

/// Surfaces of every column, stored compactly: in chunks of kChunkRows grid rows (grid.hpp),
/// each the ColumnSurfaces of its rows' columns, held by shared pointer so that an edited
/// version shares the chunks its edit did not touch.
class SurfaceMap {
 public:
  using Chunk = std::shared_ptr<const ColumnSurfaces>;

  SurfaceMap() = default;

  /// Extracts the surfaces of `cloud` (all points, finite, inside `geometry`) on `geometry`,
  /// marking as valid those whose top cell holds a point with `valid_ground[i] != 0`, and fits
  /// each surface's local plane with the points of the cylinder of radius
  /// field.plane_fit_radius_m and half-height field.plane_fit_half_height_m around it.
  static SurfaceMap Build(const GridGeometry& geometry, const PointCloud& cloud,
                          const std::vector<std::uint8_t>& valid_ground, const FieldConfig& field,
                          int num_threads);

  /// The same from a cloud already sorted into the columns of `geometry`, with its valid flags
  /// set (terrain assessment's path). `progress` (may be null) counts columns and may stop
  /// the build: kCancelled.
  static Expected<SurfaceMap> BuildFromColumns(const GridGeometry& geometry,
                                               const internal::ColumnCloud& sorted,
                                               const FieldConfig& field, int num_threads,
                                               internal::ProgressReporter* progress);

  /// A map from its arrays over the whole grid, as a saved model stores them: `column_begin`
  /// holds one offset per column (x fastest) plus the total, each column's surfaces lowest
  /// first with layers inside the grid and ground heights that do not descend. kInvalidInput
  /// naming the first inconsistency.
  static Expected<SurfaceMap> FromParts(const GridGeometry& geometry,
                                        std::vector<std::uint32_t> column_begin,
                                        std::vector<ColumnSurface> surfaces);
  /// A map from its chunks (ChunkCount(geometry) of them, chunk k the ColumnSurfaces of its
  /// ChunkRowCount rows), checked as FromParts checks, but for the chunks `checked` (may be
  /// null; a map on the same grid) holds at the same place: they were checked when it was made.
  static Expected<SurfaceMap> FromChunks(const GridGeometry& geometry, std::vector<Chunk> chunks,
                                         const SurfaceMap* checked = nullptr);
  const std::vector<Chunk>& chunks() const { return chunks_; }
  /// The whole grid's arrays (a copy of every chunk's, offsets from the grid's start): what
  /// FromParts takes. For tests and tools.
  ColumnSurfaces ToParts() const;

  const GridGeometry& geometry() const { return geometry_; }
  std::size_t surface_count() const { return surface_count_; }
  std::size_t valid_surface_count() const;
  /// The most valid surfaces one column holds (the levels a map has). Counted per chunk when the
  /// map is made (a shared chunk's count comes with it), so this costs no pass over the columns.
  int max_valid_levels() const;

  /// Surfaces of column (ix, iy), lowest first (their ground heights ascend). Precondition:
  /// inside the grid.
  std::span<const ColumnSurface> Column(int ix, int iy) const {
    const auto row = static_cast<unsigned>(iy);
    const ColumnSurfaces& chunk = *chunks_[row / kChunkRows];
    const auto c =
        static_cast<std::size_t>(ix + geometry_.size.x() * std::int64_t{row % kChunkRows});
    return {chunk.surfaces.data() + chunk.column_begin[c],
            chunk.surfaces.data() + chunk.column_begin[c + 1]};
  }

  /// Where cell (ix, iy, iz) projects down to: the highest surface whose top cell is at or
  /// below iz. nullptr when the cell lies inside an obstacle (within a run, below its top) or
  /// nothing is below it.
  const ColumnSurface* SurfaceBelow(int ix, int iy, int iz) const;

  /// Bytes held, chunks shared with other maps included.
  std::size_t MemoryBytes() const;
  /// The bytes of the chunks `other` (a map on the same grid, e.g. the base of an edit) does
  /// not hold at the same place: what making this map allocated beyond it.
  std::size_t MemoryBytesBeyond(const SurfaceMap& other) const;

 private:
  // Appends `chunk`, whose most valid surfaces in a column are `levels`.
  void Append(Chunk chunk, int levels);

  GridGeometry geometry_;
  std::vector<Chunk> chunks_;
  std::vector<int> chunk_levels_;  // Per chunk: the most valid surfaces of one of its columns.
  std::size_t surface_count_ = 0;
};

}  // namespace strata
