#pragma once
/// Edits of an assessed map without assessing it all again (docs/design.md, "Map edits"):
/// ApplyEdits makes the edited point cloud, ReassessRegion the model of it, reassessing only
/// the columns the edits can change and splicing them into a copy of the base model. The
/// result is the model TerrainModel::Assess makes of the edited cloud, value for value.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include <Eigen/Geometry>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/point_cloud.hpp"
#include "strata/prism.hpp"
#include "strata/status.hpp"

namespace strata {

/// One change to a map's point cloud.
struct MapEdit {
  enum class Kind {
    kAddObstacle,   ///< The prism becomes solid: its volume is filled with points.
    kRemovePoints,  ///< Every point inside the prism (Prism::Contains) is dropped.
    /// What a robot observed replaces what the map held in the prism: every point inside it
    /// is dropped and the scan's `points` inside it are added (thinned; see ApplyEdits).
    kScan,
  };
  Kind kind = Kind::kAddObstacle;
  Prism region;  ///< Where [m].
  /// kScan: the points the robot observed, in the map's frame [m]; those outside `region` are
  /// not added (a sensor sees past the region it vouches for). Shared, so copying an edit
  /// copies no points. Null is a scan that saw nothing: the region is emptied. Null for the
  /// other kinds.
  std::shared_ptr<const PointCloud> points;

  /// kInvalidInput blaming `path`.kind for an unknown kind, `path`.region.<field>
  /// (Prism::Validate) for a bad region, `path`.points[i] for a scan's point that is not
  /// finite and `path`.points for points on an edit that is not a scan; kResourceExhausted
  /// blaming `path`.points for a scan of more than kMaxEditPoints points.
  Status Validate(std::string_view path) const;
};

/// Most points the obstacles and scans of one ApplyEdits call may add together (about 48 MB),
/// a scan counting every point it holds: 4000 m³ of solid at a 0.1 m grid, 32000 m³ at 0.2 m.
inline constexpr std::size_t kMaxEditPoints = 4'000'000;

/// What ApplyEdits did with the scans' points.
struct ScanCounts {
  std::size_t added = 0;           ///< Inside their region and kept by the thinning.
  std::size_t outside_region = 0;  ///< Outside their region (Prism::Contains): not added.
  std::size_t thinned = 0;         ///< Inside their region, dropped by the thinning.
};

/// The cloud of `base` (assessed from `cloud`) after `edits`, applied in order: the points of
/// `cloud` that no removal or scan drops, in their order, then the points each obstacle or
/// scan adds that no later removal or scan drops, edit by edit. The same edits on the same
/// cloud and model give the same cloud, point for point.
///
/// An obstacle is a solid block on the base's grid: one point at the centre of every column of
/// the grid whose centre lies inside the polygon (Prism::ContainsXY), at every height of the
/// block's levels within [z_min_m, z_max_m]. The levels are the centres of the grid's layers
/// for a sensor's cloud and the heights of the base cloud's own lattice for a voxelised one
/// (AssessmentSummary::vertical_quantum_m), so the edited cloud keeps its vertical quantum and
/// its solids look like the map's own: on a lattice coarser than the grid the block, like the
/// map's walls, has a point every quantum.
///
/// A scan drops every point its region contains (as a removal) and adds its points the region
/// contains, in their order, thinned as the assessment thins a column: of the points in one
/// cube of edge resolution / 8 (cubes laid from the grid's origin) only the lowest, then
/// earliest, stays. So a scan adds no point the assessment would not keep, and a dense scan
/// costs no more than the cubes it fills. Its points outside the region are counted in
/// `scan_counts` (when given), not added. A scan's region must lie within the base's grid
/// (origin to origin + size · resolution): a scan replaces what the map holds and never
/// extends it past its grid. Within the grid but past the cloud's bounds it may still move
/// the grid: ReassessRegion then assesses the map in full. On a voxelised base (a vertical
/// quantum, as for obstacles) each point's height is first moved to the nearest level of the
/// base cloud's lattice, so the edited cloud keeps its quantum.
///
/// Fails with kInvalidInput naming the edit ("edits[2].region.z_max_m") for an invalid edit
/// (MapEdit::Validate), an obstacle that covers no column centre or no level (make it at
/// least one cell wide, or one quantum high) or a scan whose region leaves the grid (the
/// message gives both boxes), and with kResourceExhausted naming kMaxEditPoints when the
/// obstacles and scans would add more points (counted before anything is allocated).
Expected<PointCloud> ApplyEdits(const PointCloud& cloud, std::span<const MapEdit> edits,
                                const TerrainModel& base, ScanCounts* scan_counts = nullptr);

/// The box holding every point `edits` add or remove [m]: the union of their regions' bounds
/// (a scan's too: it adds nothing outside its region).
Eigen::AlignedBox3d EditBounds(std::span<const MapEdit> edits);

/// How ReassessRegion made its model.
enum class ReassessmentPath {
  kLocal,  ///< Only the columns around the edit were assessed again.
  kFull,   ///< The edit changed what the whole map depends on: assessed from scratch.
};

/// Stable lower_snake_case name of a path: "local" or "full".
const char* ReassessmentPathName(ReassessmentPath path);

/// What ReassessRegion made.
struct Reassessment {
  std::shared_ptr<const TerrainModel> model;
  ReassessmentPath path = ReassessmentPath::kLocal;
  /// Why the whole map was assessed again (empty for kLocal), e.g. "the edited cloud's bounds
  /// change the grid from 150 × 150 × 60 to 151 × 150 × 60 cells".
  std::string full_reason;
  /// Grid columns whose fields were computed again (the whole grid for kFull).
  std::int64_t reassessed_columns = 0;
  /// The columns whose surfaces or fields may differ from the base's (z: 0 to 0): those
  /// reassessed, and the whole grid for kFull. Every column outside holds the base's.
  CellBox changed_columns;
};

/// The model of `edited_cloud`, made from `base` (the model of `base_cloud`) by reassessing
/// only the columns the edit can change: every point `edited_cloud` adds to or lacks from
/// `base_cloud` must lie within `touched_m`'s x, y extent (EditBounds of the edits ApplyEdits
/// applied). Those columns grown by every reach of the assessment (the ground filter's radius,
/// the plane fit's radius, the distance cap, the safety diffusion's kernel) are assessed again
/// from the points around them and spliced into a copy of the base's surfaces and fields. The
/// model equals TerrainModel::Assess of `edited_cloud` (base.config(), base's quantum) in every
/// value but the summary's timings (those of the local work); SerializeModel of both differs only
/// there.
///
/// The base cloud is read for the valid-ground count of the summary: the points whose flags
/// change lie near the edit, and their old flags are not stored in the model. Each cloud is
/// read once, the sorting and filtering run on the points near the edit only.
///
/// The model keeps the base's vertical quantum (TerrainModel::Assess's `vertical_quantum_m`:
/// ApplyEdits puts its points on the base's lattice). When the edit changes what the whole map
/// depends on (the cloud's bounds move the grid, the cloud is empty or too large) the model is
/// assessed from scratch (ReassessmentPath::kFull, with the reason), failing as
/// TerrainModel::Assess.
/// kInvalidInput for a `touched_m` that is empty or not finite; kCancelled when
/// control.should_stop asked to stop.
Expected<Reassessment> ReassessRegion(const TerrainModel& base, const PointCloud& base_cloud,
                                      const PointCloud& edited_cloud,
                                      const Eigen::AlignedBox3d& touched_m,
                                      const AssessmentControl& control = {});

}  // namespace strata
