#include "maps/stored_tiles.hpp"

#include <cstdio>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include <fmt/format.h>
#include <xxhash.h>

#include "maps/store_files.hpp"
#include "strata/io/model_tiles.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kListFirstLine = "strata tiles 1";

bool IsTileName(std::string_view name) {
  return name.size() == 32 && name.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

}  // namespace

std::string TileName(std::string_view bytes) {
  return HexName(XXH3_128bits(bytes.data(), bytes.size()));
}

std::string HexName(XXH128_hash_t digest) {
  XXH128_canonical_t canonical;
  XXH128_canonicalFromHash(&canonical, digest);
  std::string hex;
  hex.reserve(32);
  constexpr char kDigits[] = "0123456789abcdef";
  for (const unsigned char byte : canonical.digest) {
    hex += kDigits[byte >> 4];
    hex += kDigits[byte & 15];
  }
  return hex;
}

std::string TerrainTiles::Format() const {
  std::string text = std::string(kListFirstLine) + "\nheader " + header + "\n";
  text += "model " + std::to_string(model.size()) + "\n";
  for (const std::string& name : model) text += name + "\n";
  text += "cloud " + std::to_string(cloud.size()) + "\n";
  for (const std::string& name : cloud) text += name + "\n";
  return text;
}

Result<TerrainTiles> TerrainTiles::Parse(std::string_view text, const fs::path& path) {
  const auto corrupted = [&](const std::string& why) {
    return MakeError(ServiceErrorCode::kMapCorrupted,
                     "map store: '" + path.string() + "' is not a list of tiles (" + why +
                         "; edited by hand?): delete the map and create it again");
  };
  std::istringstream lines{std::string(text)};
  std::string line;
  if (!std::getline(lines, line) || line != kListFirstLine) return corrupted("first line");
  TerrainTiles tiles;
  std::string word;
  if (!(lines >> word >> tiles.header) || word != "header" || !IsTileName(tiles.header)) {
    return corrupted("header");
  }
  for (auto [section, names] :
       {std::pair("model", &tiles.model), std::pair("cloud", &tiles.cloud)}) {
    std::size_t count = 0;
    // A count beyond what the text can hold is refused before anything is reserved.
    if (!(lines >> word >> count) || word != section || count > text.size() / 33) {
      return corrupted(std::string(section) + " count");
    }
    names->resize(count);
    for (std::string& name : *names) {
      if (!(lines >> name) || !IsTileName(name)) return corrupted(std::string(section) + " tile");
    }
  }
  if (lines >> word) return corrupted("trailing text");
  return tiles;
}

std::vector<std::string> TerrainTiles::Names() const {
  std::vector<std::string> names = {header};
  names.insert(names.end(), model.begin(), model.end());
  names.insert(names.end(), cloud.begin(), cloud.end());
  return names;
}

namespace {

// The tiles `which` (ascending) of a terrain of `count` tiles, cut as `tiled` and `cloud` (none
// when empty), named; every other tile named as `base`'s (all cut when it is null).
CutTerrain NameCut(const TerrainTiles* base, std::size_t count, std::span<const std::size_t> which,
                   TiledModel tiled, std::vector<std::string> cloud) {
  CutTerrain cut;
  std::unordered_set<std::string> named;
  const auto add = [&](std::string bytes) {
    std::string name = TileName(bytes);
    if (named.insert(name).second) cut.tiles.emplace_back(name, std::move(bytes));
    return name;
  };
  // Each section: the base's names, those of `which` replaced by the tiles cut now.
  const auto section = [&](std::vector<std::string> tiles, const std::vector<std::string>* kept,
                           std::vector<std::string>* names) {
    *names = kept != nullptr ? *kept : std::vector<std::string>(count);
    for (std::size_t k = 0; k < which.size(); ++k) (*names)[which[k]] = add(std::move(tiles[k]));
  };
  cut.list.header = add(std::move(tiled.header));
  section(std::move(tiled.tiles), base != nullptr ? &base->model : nullptr, &cut.list.model);
  if (!cloud.empty()) {
    section(std::move(cloud), base != nullptr ? &base->cloud : nullptr, &cut.list.cloud);
  }
  return cut;
}

}  // namespace

CutTerrain CutIntoTiles(const TerrainModel& model, const PointCloud& cloud, const BaseTiles* base) {
  const std::size_t count = TileCount(model.grid());
  if (base != nullptr && (base->list.model.size() != count ||
                          base->list.cloud.size() != (cloud.empty() ? 0 : count))) {
    base = nullptr;  // Not this grid's tiles, or no cloud where one is cut: cut them all.
  }
  std::vector<std::size_t> which;
  if (base != nullptr) {
    which = base->changed;
  } else {
    which.resize(count);
    std::iota(which.begin(), which.end(), std::size_t{0});
  }
  return NameCut(
      base != nullptr ? &base->list : nullptr, count, which, CutModelTiles(model, which),
      cloud.empty() ? std::vector<std::string>{} : CutCloudTiles(cloud, model.grid(), which));
}

ServiceStatus WriteMissingTiles(const fs::path& tiles_dir, const fs::path& tmp_dir,
                                const std::vector<std::pair<std::string, std::string>>& tiles,
                                bool durable, TileWrites* writes) {
  std::error_code ec;
  for (const auto& [name, bytes] : tiles) {
    const fs::path target = tiles_dir / name;
    if (fs::exists(target, ec)) continue;
    const fs::path temporary = tmp_dir / store_files::UniqueName("tile");
    if (ServiceStatus written = store_files::WriteNewFile(temporary, bytes, durable); !written) {
      fs::remove(temporary, ec);
      return written;
    }
    // The directory may be new, or gone with a deletion of the map: what is put after it
    // belongs to the map created next.
    fs::create_directories(tiles_dir, ec);
    // Over a tile another writer put meanwhile: the same bytes.
    if (::rename(temporary.c_str(), target.c_str()) != 0) {
      const int error = errno;
      fs::remove(temporary, ec);
      return store_files::Unavailable(target, "rename into place", error);
    }
    ++writes->written;
    writes->bytes_written += bytes.size();
  }
  return OkStatus();
}

Result<std::vector<std::string>> ReadTiles(const OpenedMapFile& tiles_dir,
                                           std::span<const std::string> names) {
  // Read through the descriptor; named as the directory was found (a map worker, which
  // inherited the descriptor, does not know where that was).
  const fs::path shown_dir =
      tiles_dir.real_path().empty() ? fs::path("the map's tiles") : tiles_dir.real_path();
  std::vector<std::string> tiles;
  tiles.reserve(names.size());
  for (const std::string& name : names) {
    const fs::path path = shown_dir / name;
    Result<std::optional<std::string>> bytes =
        store_files::ReadFileIfExists(fs::path(tiles_dir.ProcPath()) / name);
    if (!bytes) return std::move(bytes).error();
    if (!bytes->has_value()) {
      return MakeError(ServiceErrorCode::kMapVersionNotFound,
                       "map store: tile " + name + " is not in " + shown_dir.string() +
                           " (the version was pruned while it was read, or the tile removed "
                           "by hand)")
          .With("missing_tile", name);
    }
    if (TileName(**bytes) != name) {
      return MakeError(ServiceErrorCode::kMapCorrupted,
                       "map store: tile '" + path.string() +
                           "' does not hold the bytes its name says (damaged on disk?): delete "
                           "the map and create it again");
    }
    tiles.push_back(std::move(**bytes));
  }
  return tiles;
}

namespace {

ServiceError Corrupted(const Error& error) {
  return MakeError(ServiceErrorCode::kMapCorrupted,
                   "map store: " + error.message + " (delete the map and create it again)");
}

// The size of tile `tile` in `dir` [bytes]; 0 when it is not there (it fails when read).
std::uint64_t StoredTileBytes(const OpenedMapFile& dir, const std::string& tile) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(fs::path(dir.ProcPath()) / tile, ec);
  return ec ? 0 : size;
}

// Tile `tile` of `dir` for a join (JoinModel, JoinCloud), which passes on a planner's error:
// the store's own is kept in *read_error.
Expected<std::string> ReadTileForJoin(const OpenedMapFile& dir, const std::string& tile,
                                      std::optional<ServiceError>* read_error) {
  Result<std::vector<std::string>> bytes = ReadTiles(dir, std::span(&tile, 1));
  if (!bytes) {
    *read_error = bytes.error();
    return Error{ErrorCode::kMapLoadFailed, bytes.error().message};
  }
  return std::move(bytes->front());
}

}  // namespace

Result<std::shared_ptr<const TerrainModel>> LoadTiledModel(
    const OpenedTiles& tiles, const std::string& name,
    std::span<const std::pair<std::string, std::string>> given, const HeldTerrain* held,
    std::optional<CellBox>* changed_from_held) {
  if (changed_from_held != nullptr) changed_from_held->reset();
  std::unordered_map<std::string_view, const std::string*> given_by_name;
  for (const auto& [tile, bytes] : given) given_by_name.emplace(tile, &bytes);
  const auto given_bytes = [&](const std::string& tile) -> const std::string* {
    const auto it = given_by_name.find(tile);
    return it == given_by_name.end() ? nullptr : it->second;
  };
  // Read as the join asks for them, a row of blocks at a time.
  std::optional<ServiceError> read_error;
  const auto read = [&](const std::string& tile) -> Expected<std::string> {
    if (const std::string* bytes = given_bytes(tile)) return *bytes;
    return ReadTileForJoin(*tiles.dir, tile, &read_error);
  };
  Expected<std::string> header = read(tiles.list.header);
  if (!header) return *read_error;
  const TileSource source = [&](std::size_t t) { return read(tiles.list.model[t]); };
  // Their sizes first, which bound what the join allocates.
  std::uint64_t tile_bytes = 0;
  for (const std::string& tile : tiles.list.model) {
    if (const std::string* bytes = given_bytes(tile)) {
      tile_bytes += bytes->size();
      continue;
    }
    tile_bytes += StoredTileBytes(*tiles.dir, tile);
  }
  // A tile of the same name holds the same bytes (names are the contents' hashes).
  const auto shared = [&](std::size_t t) { return held->list.model[t] == tiles.list.model[t]; };
  std::optional<HeldTiles> from_held;
  if (held != nullptr && held->model != nullptr &&
      held->list.model.size() == tiles.list.model.size()) {
    from_held = HeldTiles{held->model.get(), shared};
  }
  Expected<std::shared_ptr<const TerrainModel>> model =
      JoinModel(*header, tiles.list.model.size(), tile_bytes, source, name,
                from_held ? &*from_held : nullptr);
  if (read_error) return *read_error;
  if (!model) return Corrupted(model.error());
  // The join checked the count of tiles against the grid. (A held model of another grid is
  // not used by the join, and SurfaceGraph::Patch refuses it: the graph is built.)
  if (from_held && changed_from_held != nullptr) {
    CellBox changed;  // Empty.
    for (std::size_t t = 0; t < tiles.list.model.size(); ++t) {
      if (shared(t)) continue;
      const CellBox block = TileColumns((*model)->grid(), t);
      changed = changed.empty()
                    ? block
                    : CellBox{changed.min.cwiseMin(block.min), changed.max.cwiseMax(block.max)};
    }
    *changed_from_held = changed;
  }
  return std::move(model).value();
}

Result<PointCloud> LoadTiledCloud(const OpenedTiles& tiles, const std::string& name) {
  if (tiles.list.cloud.empty()) {
    return MakeError(ServiceErrorCode::kEditNeedsCloud,
                     "the map was made from a saved model, which keeps no point cloud: create "
                     "it from its point cloud to edit it");
  }
  // A tile at a time, straight into the cloud: reading them all first held the cloud twice
  // (0.2 s more on a 400 m site, most of it the second copy's fresh memory).
  std::optional<ServiceError> read_error;
  const TileSource source = [&](std::size_t t) {
    return ReadTileForJoin(*tiles.dir, tiles.list.cloud[t], &read_error);
  };
  std::uint64_t tile_bytes = 0;
  for (const std::string& tile : tiles.list.cloud) tile_bytes += StoredTileBytes(*tiles.dir, tile);
  Expected<PointCloud> cloud = JoinCloud(tiles.list.cloud.size(), tile_bytes, source, name);
  if (read_error) return *read_error;
  if (!cloud) return Corrupted(cloud.error());
  return std::move(cloud).value();
}

Expected<StoredTerrainEdit> EditStoredTerrain(const OpenedTiles& base,
                                              std::span<const MapEdit> edits,
                                              const AssessmentControl& control) {
  StoredTerrainEdit out;
  const TerrainTiles& list = base.list;
  if (list.cloud.size() != list.model.size()) {
    out.edit.needs_whole = "the version keeps no cloud in tiles";
    return out;
  }
  std::optional<ServiceError> read_error;
  Expected<std::string> header = ReadTileForJoin(*base.dir, list.header, &read_error);
  if (!header) return header.error();
  const auto reader = [&](const std::vector<std::string>& names) {
    return [&](std::size_t t) -> Expected<std::string> {
      if (t >= names.size()) {
        return Error{ErrorCode::kMapLoadFailed,
                     fmt::format("the map's current version lists {} tiles; its header's grid "
                                 "has tile {}",
                                 names.size(), t)};
      }
      return ReadTileForJoin(*base.dir, names[t], &read_error);
    };
  };
  const TiledTerrainSource source{*header, reader(list.model), reader(list.cloud)};
  Expected<TiledTerrainEdit> edit = EditTiledTerrain(source, edits, control);
  if (!edit) return edit.error();
  out.edit = std::move(edit).value();
  if (!out.edit.needs_whole.empty()) return out;
  out.cut = NameCut(&list, list.model.size(), out.edit.changed, std::move(out.edit.model),
                    std::move(out.edit.cloud));
  out.edit.model = {};
  out.edit.cloud = {};
  return out;
}

}  // namespace strata::server
