#pragma once
/// Assessed models and their clouds cut into tiles, so that a map store keeps each tile once,
/// by its content, and a version that changes a few of them writes only those
/// (docs/design.md §8, "Tiled terrains").
///
/// A tile is a block of kTileColumns × kTileColumns grid columns (smaller at the grid's far
/// edges); tiles are numbered row-major over the blocks. A tiled model is:
/// - a header: a framed file like a saved model (magic "STRATAMT", the saved-model format
///   version, the writer, an XXH3-64 checksum) holding the parameters, the summary, the grid
///   and the fields' scalars;
/// - one tile per block: per column its surfaces, then per column its fields' stored runs of
///   layers and their values. A tile's bytes depend on its own columns only, so the tiles an
///   edit did not reassess are the base's tiles, byte for byte.
/// A cloud is cut along the same blocks: a tile holds the points whose column (clamped onto
/// the grid) lies in the block, in the cloud's order, as float32 x y z.
///
/// A tile holds no checksum of its own: its name in the store is its content's hash, which
/// the store checks when it reads it.

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "strata/assessment/terrain_model.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

/// Grid columns along each side of a tile: 64 columns are 12.8 m at 0.2 m, so a 10 m scan
/// touches 4 to 9 of them with its reassessed margin, and a 400 m site has 1024. A row of
/// tiles is one chunk of the model's arrays (grid.hpp), so a join takes the chunks of the rows
/// whose tiles it holds already as they are.
inline constexpr int kTileColumns = kChunkRows;

/// The first bytes of a tiled model's header.
inline constexpr std::string_view kTiledModelMagic = "STRATAMT";

/// A model cut into its header and its tiles.
struct TiledModel {
  std::string header;
  std::vector<std::string> tiles;  ///< Row-major over the blocks (TileCount).
};

/// How many tiles a grid of `geometry`'s columns is cut into.
std::size_t TileCount(const GridGeometry& geometry);

/// `model` cut into tiles. JoinModel of them makes a model whose SerializeModel equals
/// `model`'s, byte for byte.
TiledModel CutModel(const TerrainModel& model);

/// The tiles (ascending) whose blocks hold a column of `columns` (x, y; z is ignored) on the
/// grid `geometry`.
std::vector<std::size_t> TilesTouching(const GridGeometry& geometry, const CellBox& columns);

/// The columns of tile `tile` (below TileCount) on the grid `geometry`: its block, over the
/// grid's whole height.
CellBox TileColumns(const GridGeometry& geometry, std::size_t tile);

/// CutModel's header, and of its tiles only those numbered `which` (ascending, each below
/// TileCount), in that order: what an edit that changed only their blocks must write anew.
TiledModel CutModelTiles(const TerrainModel& model, std::span<const std::size_t> which);

/// Where JoinModel reads tile `t` (0 to TileCount - 1) from: its bytes, or an error JoinModel
/// passes on as it is. Each tile is asked for once, in increasing order.
using TileSource = std::function<Expected<std::string>(std::size_t t)>;

/// Tiles a join takes from a model already in memory instead of reading and decoding them:
/// `model`'s tile t for each t that `same(t)` says is CutModel(*model).tiles[t], byte for byte
/// (a store knows it from the tiles' names, which are their contents' hashes). A replica
/// that holds a version of a map loads the next one so, reading only the tiles it changed.
struct HeldTiles {
  const TerrainModel* model = nullptr;
  std::function<bool(std::size_t t)> same;
};

/// The model of a header and its `tile_count` tiles of `tile_bytes` bytes together, read from
/// `source` one row of blocks at a time (memory: the model and one row of tiles); `name` is
/// what messages call it. With `held` (may be null), the tiles it holds are taken from its
/// model, not asked of `source`, when its grid has the header's columns (else it is not
/// used): a row of tiles it holds all is its model's chunk (grid.hpp), shared, and the
/// others' columns are copied into the new chunks. kMapLoadFailed naming it for a header that is
/// not one, of another format version, truncated or corrupted (its checksum), a count of tiles
/// other than the header's grid needs, totals the tiles' bytes cannot hold, tiles past
/// `tile_bytes`, and a tile whose contents do not fit its block or the header's totals (which tile,
/// and why). Never allocates more than `tile_bytes` plus the header's grid of column offsets.
Expected<std::shared_ptr<const TerrainModel>> JoinModel(
    std::string_view header, std::size_t tile_count, std::uint64_t tile_bytes,
    const TileSource& source, const std::string& name, const HeldTiles* held = nullptr);
/// JoinModel of tiles in memory.
Expected<std::shared_ptr<const TerrainModel>> JoinModel(std::string_view header,
                                                        std::span<const std::string_view> tiles,
                                                        const std::string& name);

/// What a tiled model's header says of the whole model.
struct TiledModelHeader {
  AssessmentConfig config;
  AssessmentSummary summary;
  GridGeometry grid;
};

/// The header `header` holds; kMapLoadFailed naming `name` as JoinModel refuses one.
Expected<TiledModelHeader> ReadTiledModelHeader(std::string_view header, const std::string& name);

/// A window of a tiled model, for an edit that reads only the model around it: a model on the
/// header's grid, with its config and summary (whose counts are the whole model's), holding
/// the tiles `which` (ascending, read from `source`) as JoinModel would, and no surface and no
/// field run in any other column. Its memory is the chunks (grid.hpp) of those tiles' rows,
/// and one chunk of empty columns shared by every other row.
/// Fails as JoinModel does for the tiles it reads, and kMapLoadFailed for a tile number past
/// the header's grid.
Expected<std::shared_ptr<const TerrainModel>> JoinModelWindow(std::string_view header,
                                                              std::span<const std::size_t> which,
                                                              const TileSource& source,
                                                              const std::string& name);

/// CutModelTiles for windows: the header of the model whose tiles are those of `base_header`'s
/// with tiles `which` (ascending) replaced by `edited`'s, and those tiles. `edited` and `base`
/// (windows of JoinModelWindow, or whole models) must hold every column of those tiles, and
/// `edited`'s config, summary and scalars are the header's. kMapLoadFailed when `base_header`
/// is not a header.
Expected<TiledModel> CutEditedTiles(const TerrainModel& edited, const TerrainModel& base,
                                    std::string_view base_header,
                                    std::span<const std::size_t> which);

/// `cloud` cut along the tiles of the grid `geometry` (the model's): TileCount(geometry)
/// tiles, empty ones included.
std::vector<std::string> CutCloud(const PointCloud& cloud, const GridGeometry& geometry);

/// Of CutCloud's tiles only those numbered `which` (ascending, each below TileCount), in that
/// order.
std::vector<std::string> CutCloudTiles(const PointCloud& cloud, const GridGeometry& geometry,
                                       std::span<const std::size_t> which);

/// The points of `tiles`, tile after tile; kMapLoadFailed naming `name` when a tile is not a
/// whole number of points.
Expected<PointCloud> JoinCloud(std::span<const std::string_view> tiles, const std::string& name);

/// The same of `tile_count` tiles of about `tile_bytes` bytes together (what is reserved),
/// read from `source` one at a time (memory: the cloud and one tile), its errors passed on.
Expected<PointCloud> JoinCloud(std::size_t tile_count, std::uint64_t tile_bytes,
                               const TileSource& source, const std::string& name);

}  // namespace strata
