#pragma once
/// The signed distance field d and the diffused safety penalty S' of an assessed map, stored
/// only on the band of cells where the planner reads them (docs/design.md §4, §6).
///
/// The planner samples both fields at the trajectory's reference point, which stays on a
/// robot's height above valid ground. So each column keeps its cells from one layer below the
/// ground of every valid surface in it or in one of its 8 neighbours up to one layer above
/// ground + band_height_m (GridConfig): every corner a trilinear sample near valid ground can
/// touch. A column holds one run of layers (an "interval") per level, and both fields share
/// the intervals. Nothing is stored for the air over a valley, the rock under a hill or the
/// inside of a building's walls, so memory grows with the ground, not with the bounding box.
///
/// Values are those of the dense fields on the whole grid (BuildSignedDistanceField,
/// ComputeSafetyPenalty, DiffuseSafetyPenalty), with two documented changes:
/// - d is exact up to GridConfig::distance_cap_m from the nearest cell of the other class and
///   reads ± the cap beyond it (the planner's thresholds are all far below it), which lets
///   each tile be transformed on its own with a halo of the cap;
/// - values are quantised to 16 bits: d in steps of kDistanceStepM (1 mm, on a field whose
///   cells are >= 2 cm), S' in steps of its largest possible value / 65535.
/// The interpolant of the quantised values is trilinear, so its gradient is exact (the
/// finite-difference tests hold). A corner outside the band reads the background: the cap for
/// d (far from everything) and FieldConfig::VoidPenalty() for S' (unknown is unsafe).

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/status.hpp"

namespace strata {

/// The trilinear block a sample reads (the cell of centres around it) and the extremes of its
/// eight corner values: both fields are convex combinations of those corners anywhere in the
/// block, so they stay within these bounds there.
struct FieldBlock {
  std::int64_t key = -1;    ///< TerrainFields::BlockKey of the block.
  double max_safety = 0;    ///< The largest S' of its corners [-].
  double min_distance = 0;  ///< The least d of its corners [m].
};

/// Both fields at one point, with their gradients.
struct FieldSample {
  double distance_m = 0;                                        ///< d [m].
  Eigen::Vector3d distance_gradient = Eigen::Vector3d::Zero();  ///< ∇d [-].
  double safety = 0;                                            ///< S' [-].
  Eigen::Vector3d safety_gradient = Eigen::Vector3d::Zero();    ///< ∇S' [1/m].
};

class TerrainFields {
 public:
  /// Quantisation step of d [m].
  static constexpr double kDistanceStepM = 1e-3;
  /// Largest |d| a stored value can hold [m]; GridConfig::distance_cap_m is at most this.
  static constexpr double kMaxDistanceM = 32.0;

  /// A run of stored layers of one column: layers [first_layer, first_layer + count), values
  /// at [offset, offset + count) of each field, count being the next interval's offset minus
  /// this one's (the last interval is a sentinel holding the total).
  struct Interval {
    std::int32_t first_layer = 0;
    std::uint32_t offset = 0;
  };

  /// The fields of some columns: per column (x fastest) + 1, the first of its intervals; the
  /// intervals, with a final sentinel whose offset is the count of values; per stored cell, the
  /// values.
  struct Runs {
    std::vector<std::uint32_t> column_begin;
    std::vector<Interval> intervals;     ///< Including the final sentinel.
    std::vector<std::int16_t> distance;  ///< d / kDistanceStepM per stored cell.
    std::vector<std::uint16_t> safety;   ///< S' / safety_step per stored cell.
  };
  /// What the fields hold besides their runs.
  struct Scalars {
    GridGeometry geometry;
    double distance_cap_m = 0;
    double safety_step = 0;        ///< S' per unit of a stored value.
    double safety_background = 0;  ///< S' outside the band.
  };
  /// The scalars and the runs of a window of columns: what BuildFieldParts makes, and over the
  /// whole grid what a saved model stores.
  struct Parts : Scalars, Runs {};
  /// The runs of kChunkRows grid rows (grid.hpp), shared between the versions of a map that
  /// did not change them.
  using Chunk = std::shared_ptr<const Runs>;

  TerrainFields() = default;

  /// Validates `parts` over the whole grid (sizes, offsets, layers inside the grid, steps) and
  /// takes them, cut into chunks; kInvalidInput naming the inconsistency.
  static Expected<TerrainFields> FromParts(const Parts& parts);
  /// The fields of `scalars` and `chunks` (ChunkCount(geometry) of them, chunk k the runs of
  /// its ChunkRowCount rows), checked as FromParts checks, but for the chunks `checked` (may be
  /// null; fields on the same grid) holds at the same place: they were checked when it was
  /// made.
  static Expected<TerrainFields> FromChunks(const Scalars& scalars, std::vector<Chunk> chunks,
                                            const TerrainFields* checked = nullptr);
  /// The whole grid's parts (a copy of every chunk's runs, offsets from the grid's start): what
  /// FromParts takes. For tests and tools.
  Parts ToParts() const;
  const Scalars& scalars() const { return scalars_; }
  const std::vector<Chunk>& chunks() const { return chunks_; }

  const GridGeometry& geometry() const { return scalars_.geometry; }
  double distance_cap_m() const { return scalars_.distance_cap_m; }

  /// d(p) [m], trilinear over cell centres; gradient optional [-]. Outside the hull of cell
  /// centres p is clamped onto it (those gradient components are then zero), as ScalarGrid.
  double Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const;
  /// S'(p) [-], likewise; gradient optional [1/m].
  double SafetyPenalty(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr) const;
  /// Both, sharing one lookup of the eight corners (what the optimiser's cost reads); with
  /// `block`, also the block they came from and its bounds.
  void Sample(const Eigen::Vector3d& p, FieldSample* sample, FieldBlock* block = nullptr) const;
  /// The block a sample at p reads, as one number: equal for two points exactly when their
  /// samples interpolate between the same eight corners. Cheaper than a sample: no lookup.
  std::int64_t BlockKey(const Eigen::Vector3d& p) const;

  /// What d can be anywhere in `box` (the verifier's enclosure of a stretch of path between
  /// two samples): the least corner value of every trilinear block the box meets, and a bound
  /// on |∇d| there. In a block ∂d/∂x is a weighted mean of the block's four differences
  /// along x over the resolution (likewise y, z), so the norm of the largest difference along
  /// each axis between neighbouring corners of those blocks, over the resolution, bounds it.
  /// A box beyond the hull of cell centres reads the clamped blocks (their gradient is smaller).
  struct DistanceBounds {
    double min_m = 0;      ///< d >= this in the box [m].
    double max_slope = 0;  ///< |∇d| <= this in the box [-].
  };
  DistanceBounds DistanceBoundsIn(const Eigen::AlignedBox3d& box) const;

  /// The stored values at a cell, or nothing outside the band. For tests and tools.
  std::optional<double> DistanceAt(const Eigen::Vector3i& cell) const;
  std::optional<double> SafetyAt(const Eigen::Vector3i& cell) const;

  /// Cells stored (in the band).
  std::size_t cell_count() const { return cell_count_; }
  /// Bytes held, not counting the object itself, chunks shared with other fields included.
  std::size_t MemoryBytes() const;
  /// The bytes of the chunks `other` (fields on the same grid, e.g. the base of an edit) does
  /// not hold at the same place: what making these fields allocated beyond it.
  std::size_t MemoryBytesBeyond(const TerrainFields& other) const;

 private:
  // A stored cell: its chunk's runs and the index of its values there; runs == nullptr
  // outside the band or the grid.
  struct CellRef {
    const Runs* runs = nullptr;
    std::int64_t index = 0;
  };
  CellRef FindCell(const Eigen::Vector3i& cell) const;
  // The value of a stored cell, or the field's background (outside the band).
  double DistanceValue(const CellRef& at) const {
    return at.runs == nullptr ? scalars_.distance_cap_m
                              : at.runs->distance[at.index] * kDistanceStepM;
  }
  double SafetyValue(const CellRef& at) const {
    return at.runs == nullptr ? scalars_.safety_background
                              : at.runs->safety[at.index] * scalars_.safety_step;
  }
  // The corners of the sample at p (terrain_fields.cpp).
  struct Corners;
  Corners Locate(const Eigen::Vector3d& p) const;

  Scalars scalars_;
  std::vector<Chunk> chunks_;
  std::size_t cell_count_ = 0;
};

}  // namespace strata
