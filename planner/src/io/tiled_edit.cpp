#include "strata/io/tiled_edit.hpp"

#include <array>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "assessment/column_cloud.hpp"
#include "assessment/map_edit_internal.hpp"
#include "assessment/terrain_model_internal.hpp"

namespace strata {
namespace {

// The new summary's bounds from the base's, when the tiles read tell them: `base` bounds the
// whole base cloud, `read` the points of the tiles read, `edited` those points edited. A face
// of `base` that a point read lies on holds only while an edited point still does; false
// when none does (another tile may or may not hold one).
bool EditedBounds(const Eigen::AlignedBox3d& base, const Eigen::AlignedBox3d& read,
                  const Eigen::AlignedBox3d& edited, Eigen::AlignedBox3d* out) {
  for (int i = 0; i < 3; ++i) {
    const bool lows_lost = read.min()[i] == base.min()[i] && !(edited.min()[i] <= base.min()[i]);
    const bool highs_lost = read.max()[i] == base.max()[i] && !(edited.max()[i] >= base.max()[i]);
    if (lows_lost || highs_lost) return false;
  }
  *out = base;
  if (!edited.isEmpty()) out->extend(edited);
  return true;
}

Eigen::AlignedBox3d BoundsOf(const PointCloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3f& p : cloud) box.extend(p.cast<double>());
  return box;
}

}  // namespace

Expected<TiledTerrainEdit> EditTiledTerrain(const TiledTerrainSource& source,
                                            std::span<const MapEdit> edits,
                                            const AssessmentControl& control) {
  internal::Stopwatch stage;
  Expected<TiledModelHeader> header = ReadTiledModelHeader(source.model_header, "of the base");
  if (!header) return header.error();
  const GridGeometry& g = header->grid;
  const AssessmentSummary& base_summary = header->summary;
  const Eigen::AlignedBox3d touched_m = EditBounds(edits);
  if (Status s = internal::ValidateTouched(touched_m); !s) return s.error();
  const internal::EditReach reach =
      internal::ReachOfEdit(header->config, g, base_summary.vertical_quantum_m, touched_m);

  // The model's tiles whose columns the new fields read (the changed ones among them), and
  // the cloud's whose points the reassessment reads (those of the changed tiles among them).
  const std::vector<std::size_t> model_tiles = TilesTouching(g, reach.surfaces_read);
  const std::vector<std::size_t> cloud_tiles = TilesTouching(g, reach.crop);
  Expected<std::shared_ptr<const TerrainModel>> base =
      JoinModelWindow(source.model_header, model_tiles, source.model_tile, "of the base");
  if (!base) return base.error();
  std::vector<std::string> bytes;
  bytes.reserve(cloud_tiles.size());
  for (const std::size_t t : cloud_tiles) {
    Expected<std::string> tile = source.cloud_tile(t);
    if (!tile) return tile.error();
    bytes.push_back(std::move(tile).value());
  }
  const std::vector<std::string_view> views(bytes.begin(), bytes.end());
  Expected<PointCloud> read = JoinCloud(views, "of the base");
  if (!read) return read.error();
  bytes = {};

  TiledTerrainEdit out;
  Expected<PointCloud> edited = ApplyEdits(*read, edits, **base, &out.scans);
  if (!edited) return edited.error();
  out.apply_s = stage.Lap();

  AssessmentSummary summary = base_summary;
  summary.input_points = base_summary.input_points - read->size() + edited->size();
  if (summary.input_points == 0) {
    out.needs_whole = "the edit empties the cloud";
    return out;
  }
  if (!EditedBounds(base_summary.cloud_bounds_m, BoundsOf(*read), BoundsOf(*edited),
                    &summary.cloud_bounds_m)) {
    out.needs_whole = "the edit drops a point on the cloud's bounding box";
    return out;
  }
  if (std::string change = internal::GridChange(g, summary, header->config.grid); !change.empty()) {
    out.needs_whole = std::move(change);
    return out;
  }
  const int threads = header->config.num_threads;
  const PointCloud near = internal::CropToColumns(g, reach.crop, *edited, threads);
  const PointCloud near_base = internal::CropToColumns(g, reach.base_crop, *read, threads);
  Expected<Reassessment> reassessed =
      internal::ReassessNear(**base, reach, summary, near, near_base, control);
  if (!reassessed) return reassessed.error();

  out.changed = TilesTouching(g, reach.fields_changed);
  Expected<TiledModel> cut =
      CutEditedTiles(*reassessed->model, **base, source.model_header, out.changed);
  if (!cut) return cut.error();
  out.model = std::move(cut).value();
  out.cloud = CutCloudTiles(*edited, g, out.changed);
  out.changed_columns = reassessed->changed_columns;
  out.reassessed_columns = reassessed->reassessed_columns;
  out.cloud_points = summary.input_points;
  out.config = header->config;
  out.reassess_s = stage.Lap();
  return out;
}

}  // namespace strata
