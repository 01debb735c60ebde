#pragma once
/// Edits of a tiled terrain that read only the tiles around them (docs/design.md, "Map
/// edits"): the points and the model of the columns an edit's reassessment reads, never the
/// whole cloud or model. So a 10 m scan of a site costs what its few tiles cost, whatever the
/// site's size. The result is what ApplyEdits and ReassessRegion make of the whole terrain
/// (the cloud as its tiles hold it, tile after tile), cut into the tiles that changed.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "strata/assessment/assessment_control.hpp"
#include "strata/assessment/grid.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/status.hpp"

namespace strata {

/// A tiled terrain (model and cloud, cut along the same blocks), read tile by tile.
struct TiledTerrainSource {
  std::string_view model_header;  ///< The tiled model's header (CutModel).
  TileSource model_tile;          ///< Model tile t's bytes.
  TileSource cloud_tile;          ///< Cloud tile t's bytes (CutCloud).
};

/// What EditTiledTerrain made: the new terrain's header and the tiles the edit changed.
struct TiledTerrainEdit {
  /// Not empty: the edit needs the whole cloud (it may move the cloud's bounds past what its
  /// tiles tell, or empties the cloud), and nothing else below is set.
  std::string needs_whole;
  TiledModel model;                  ///< The new header and model tiles `changed`, in order.
  std::vector<std::string> cloud;    ///< The edited cloud's tiles `changed`, in order.
  std::vector<std::size_t> changed;  ///< Ascending; every other tile is the base's.
  CellBox changed_columns;           ///< Reassessment::changed_columns.
  std::int64_t reassessed_columns = 0;
  std::uint64_t cloud_points = 0;  ///< Points of the whole edited cloud.
  AssessmentConfig config;         ///< The terrain's parameters (its header's).
  ScanCounts scans;                ///< ApplyEdits's.
  double apply_s = 0;              ///< Reading the tiles and editing their points [s].
  double reassess_s = 0;           ///< Reassessing and cutting the changed tiles [s].
};

/// `edits` applied to the terrain `source` holds, reassessed as ReassessRegion does, reading
/// only the cloud tiles whose points the reassessment reads and the model tiles whose columns
/// it reads or changes. The edited cloud is the base's as its tiles hold it (tile after tile,
/// each in its order) with the edits applied as ApplyEdits applies them; the model equals
/// TerrainModel::Assess of it (the base's config and quantum), and the new terrain is the
/// base's tiles with `changed` replaced, byte for byte as CutModel and CutCloud cut it whole.
/// On a voxelised map a scan's heights go to the lattice the points of those tiles hold (the
/// most common height of their sample; ApplyEdits).
///
/// The whole cloud's bounds come from the base's summary: where a tile read holds a point on
/// the bounding box and the edit leaves none there, or the edit would move the grid or empty
/// the cloud, `needs_whole` says why and the caller edits the whole terrain instead. Fails as
/// ApplyEdits does for bad edits, as the sources do, kMapLoadFailed for tiles that do not fit
/// the header, and kCancelled when control.should_stop asked to stop.
Expected<TiledTerrainEdit> EditTiledTerrain(const TiledTerrainSource& source,
                                            std::span<const MapEdit> edits,
                                            const AssessmentControl& control = {});

}  // namespace strata
