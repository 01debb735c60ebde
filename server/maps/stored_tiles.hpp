#pragma once
/// The tiles a map store keeps its terrains in (layout 3; strata/io/model_tiles.hpp cuts
/// them): each tile once per map, named by its content, shared by every terrain that lists
/// it. A terrain made by an edit lists its base's tiles wherever the edit changed nothing,
/// so it costs the bytes of the tiles it changed.
///
///   maps/<id>/tiles/<name>        one tile's bytes; <name> is their XXH3-128 in lowercase
///                                 hex (TileName), checked on every read
///   maps/<id>/terrains/<t>/tiles  the terrain's list of tiles (TerrainTiles::Format)
///
/// No gRPC, no locks: maps/map_store.cpp decides when tiles are written and collected.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <xxhash.h>

#include "common/service_error.hpp"
#include "maps/map_root.hpp"
#include "strata/assessment/map_edit.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/tiled_edit.hpp"
#include "strata/point_cloud.hpp"

namespace strata::server {

/// An XXH3-128 digest as the store names things by it: 32 lowercase hex digits.
std::string HexName(XXH128_hash_t digest);

/// The name a tile of `bytes` is kept under: HexName of their XXH3-128.
std::string TileName(std::string_view bytes);

/// One terrain's tiles, by name.
struct TerrainTiles {
  std::string header;              ///< The tiled model's header.
  std::vector<std::string> model;  ///< The model's tiles, in order (TileCount).
  std::vector<std::string> cloud;  ///< The cloud's tiles, in order; empty: no cloud kept.

  /// The list as the terrain keeps it: "strata tiles 1", then "header <name>", "model <n>"
  /// and n names, "cloud <n>" and n names, one per line.
  std::string Format() const;
  /// The list `text` holds; kMapCorrupted naming `path` when it is not one.
  static Result<TerrainTiles> Parse(std::string_view text, const std::filesystem::path& path);
  /// Every name it lists (with repeats).
  std::vector<std::string> Names() const;
};

/// What an edit keeps of its base's terrain: the base's list, and the tiles (ascending
/// indices into the model's; the cloud is cut along the same blocks) whose blocks the edit may
/// have changed (TilesTouching Reassessment::changed_columns). Every other tile of the edited
/// terrain is the base's, byte for byte.
struct BaseTiles {
  TerrainTiles list;
  std::vector<std::size_t> changed;
};

/// A terrain cut into tiles, with their names: what PutTerrain writes.
struct CutTerrain {
  TerrainTiles list;
  /// The bytes of every tile cut, each name once, in the list's order.
  std::vector<std::pair<std::string, std::string>> tiles;
};

/// `model` and `cloud` (empty: none kept) cut into tiles and named. With a `base` (may be
/// null) that fits them (its list has as many model tiles as `model`'s grid, and a cloud when
/// `cloud` is not empty) only its changed tiles are cut; the others are named as the base's.
CutTerrain CutIntoTiles(const TerrainModel& model, const PointCloud& cloud,
                        const BaseTiles* base = nullptr);

/// What writing a terrain's tiles cost (MapStore::PutTerrain).
struct TileWrites {
  int written = 0;                  ///< Tiles the store did not hold.
  int shared = 0;                   ///< Tiles it held already (another terrain lists them).
  std::uint64_t bytes_written = 0;  ///< Of the tiles written and the terrain's list.
  std::uint64_t list_bytes = 0;     ///< Of the list alone (part of bytes_written).
};

/// Writes each of `tiles` that `tiles_dir` lacks: to a temporary in `tmp_dir`, made durable
/// when `durable` (else the caller syncs the file system once for all of them), renamed into
/// place; the directory itself is not synced. Adds what it writes to `*writes` (written,
/// bytes_written). kMapStoreUnavailable naming the path.
ServiceStatus WriteMissingTiles(const std::filesystem::path& tiles_dir,
                                const std::filesystem::path& tmp_dir,
                                const std::vector<std::pair<std::string, std::string>>& tiles,
                                bool durable, TileWrites* writes);

/// The bytes of tiles `names` in the directory `tiles_dir` (opened), in order. kMapCorrupted naming
/// the file for a tile whose bytes are not those its name says, kMapVersionNotFound naming it for
/// one that is not there (ServiceError::detail "missing_tile"), kMapStoreUnavailable when one
/// cannot be read.
Result<std::vector<std::string>> ReadTiles(const OpenedMapFile& tiles_dir,
                                           std::span<const std::string> names);

/// A tiled terrain, opened for an edit: the directory of its map's tiles (a descriptor, which a
/// map worker inherits) and the terrain's list of them.
struct OpenedTiles {
  std::shared_ptr<const OpenedMapFile> dir;
  TerrainTiles list;
};

/// A model this process holds and the list of tiles it is made of.
struct HeldTerrain {
  std::shared_ptr<const TerrainModel> model;
  TerrainTiles list;
};

/// The model of `tiles`, read through its directory and joined; `name` is what messages call
/// it. The tiles of `given` (a map worker's cut: the tiles an edit changed, with their names)
/// are taken from there, those `held` (may be null) lists at the same place (another version
/// of the map, held here) from its model, and the others read from the directory. Fails as
/// ReadTiles does, and kMapCorrupted as JoinModel refuses. `changed_from_held` (may be null):
/// set, when the held model was used, to the columns where the two may differ (the blocks of
/// the tiles not taken from it, in one box; empty when all were), else left empty.
Result<std::shared_ptr<const TerrainModel>> LoadTiledModel(
    const OpenedTiles& tiles, const std::string& name,
    std::span<const std::pair<std::string, std::string>> given = {},
    const HeldTerrain* held = nullptr, std::optional<CellBox>* changed_from_held = nullptr);
/// The cloud of `tiles`, in the order of its tiles (kEditNeedsCloud when it keeps none); fails
/// as LoadTiledModel does.
Result<PointCloud> LoadTiledCloud(const OpenedTiles& tiles, const std::string& name);

/// What EditStoredTerrain made.
struct StoredTerrainEdit {
  /// Its figures (its tiles moved into `cut`); needs_whole not empty: nothing was made.
  TiledTerrainEdit edit;
  CutTerrain cut;  ///< The edited terrain's list, and the tiles it changed.
};

/// `edits` of the tiled terrain `base`, reading only its tiles around them (EditTiledTerrain),
/// its changed tiles named as CutIntoTiles names an edit's. Fails as EditTiledTerrain does, a
/// tile that cannot be read with kMapLoadFailed saying why.
Expected<StoredTerrainEdit> EditStoredTerrain(const OpenedTiles& base,
                                              std::span<const MapEdit> edits,
                                              const AssessmentControl& control);

}  // namespace strata::server
