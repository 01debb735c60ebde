#include "strata/io/model_tiles.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>

#include "binary_file.hpp"
#include "column_chunks_internal.hpp"
#include "model_parts.hpp"
#include "strata/io/saved_model.hpp"

namespace strata {
namespace {

using binary_file::Decode;
using binary_file::Encode;
using model_parts::kSurfaceRecordBytes;

// The header's meaning follows the saved model's: a model assessed by another rule is not
// joined either.
const binary_file::FileKind kTiledModelKind{kTiledModelMagic, kSavedModelFormatVersion,
                                            "tiled model", "assess the map again with this build"};

constexpr std::size_t kCountBytes = 4;      // u32 per column: surfaces, runs.
constexpr std::size_t kRunBytes = 4 + 4;    // i32 first layer, u32 layers.
constexpr std::size_t kValueBytes = 2 + 2;  // i16 distance, u16 safety per layer.
constexpr std::size_t kPointBytes = 3 * 4;  // float32 x y z.

// A block of columns: [x0, x1) × [y0, y1).
struct Block {
  int x0, x1, y0, y1;
  std::size_t columns() const { return std::size_t(x1 - x0) * std::size_t(y1 - y0); }
};

int BlocksAlong(int columns) { return (columns + kTileColumns - 1) / kTileColumns; }

// The end of the run of blocks, from column `x` of a row `width` columns wide, whose flags in
// `flags` (one per block of the row) equal the flag of x's block.
int EndOfBlockRun(const std::vector<bool>& flags, int x, int width) {
  const bool flag = flags[x / kTileColumns];
  int end = x;
  while (end < width && flags[end / kTileColumns] == flag) end += kTileColumns;
  return std::min(end, width);
}

Block BlockOf(const GridGeometry& g, std::size_t tile) {
  const int bx = static_cast<int>(tile % BlocksAlong(g.size.x()));
  const int by = static_cast<int>(tile / BlocksAlong(g.size.x()));
  return {bx * kTileColumns, std::min(g.size.x(), (bx + 1) * kTileColumns), by * kTileColumns,
          std::min(g.size.y(), (by + 1) * kTileColumns)};
}

template <typename T>
void Append(std::string* out, T value) {
  char bytes[sizeof(T)];
  Encode(bytes, value);
  out->append(bytes, sizeof(T));
}

// The chunk that holds `block`'s columns (a row of blocks is one chunk), and the index
// there of column (x, y) of the block.
int ChunkOf(const Block& block) { return block.y0 / kChunkRows; }
std::int64_t ColumnInChunk(const GridGeometry& g, int x, int y) {
  return x + std::int64_t{g.size.x()} * (y % kChunkRows);
}

std::string CutTile(const TerrainModel& model, const Block& block) {
  const ColumnSurfaces& surfaces = *model.surfaces().chunks()[ChunkOf(block)];
  const TerrainFields::Runs& f = *model.fields().chunks()[ChunkOf(block)];
  const auto for_each_column = [&](const auto& visit) {
    for (int y = block.y0; y < block.y1; ++y) {
      for (int x = block.x0; x < block.x1; ++x) visit(ColumnInChunk(model.grid(), x, y));
    }
  };
  std::string tile;
  const std::vector<std::uint32_t>& surface_begin = surfaces.column_begin;
  for_each_column([&](std::int64_t c) {
    Append<std::uint32_t>(&tile, surface_begin[c + 1] - surface_begin[c]);
  });
  for_each_column([&](std::int64_t c) {
    for (std::uint32_t i = surface_begin[c]; i < surface_begin[c + 1]; ++i) {
      char bytes[kSurfaceRecordBytes];
      model_parts::EncodeSurface(surfaces.surfaces[i], bytes);
      tile.append(bytes, sizeof(bytes));
    }
  });
  for_each_column([&](std::int64_t c) {
    Append<std::uint32_t>(&tile, f.column_begin[c + 1] - f.column_begin[c]);
  });
  for_each_column([&](std::int64_t c) {
    for (std::uint32_t k = f.column_begin[c]; k < f.column_begin[c + 1]; ++k) {
      Append<std::int32_t>(&tile, f.intervals[k].first_layer);
      Append<std::uint32_t>(&tile, f.intervals[k + 1].offset - f.intervals[k].offset);
    }
  });
  const auto values = [&](std::int64_t c) {
    return std::pair(f.intervals[f.column_begin[c]].offset,
                     f.intervals[f.column_begin[c + 1]].offset);
  };
  for_each_column([&](std::int64_t c) {
    const auto [begin, end] = values(c);
    tile.append(reinterpret_cast<const char*>(f.distance.data() + begin),
                (end - begin) * sizeof(std::int16_t));
  });
  for_each_column([&](std::int64_t c) {
    const auto [begin, end] = values(c);
    tile.append(reinterpret_cast<const char*>(f.safety.data() + begin),
                (end - begin) * sizeof(std::uint16_t));
  });
  return tile;
}

// What the header holds besides the arrays.
struct Header {
  model_parts::Payload payload;     // Arrays empty.
  std::int32_t sentinel_layer = 0;  // Read, of no meaning (WriteHeaderWith).
  // What the tiles hold together, so that the arrays are allocated once.
  std::uint64_t surface_total = 0, run_total = 0, value_total = 0;
};

// The header of `model`, whose tiles hold these totals.
void WriteHeaderWith(binary_file::Sink& sink, const TerrainModel& model,
                     std::uint64_t surface_total, std::uint64_t run_total,
                     std::uint64_t value_total) {
  binary_file::WriteFields(sink, model.config());
  binary_file::WriteFields(sink, model.summary());
  model_parts::WriteGeometry(sink, model.grid());
  const TerrainFields::Scalars& f = model.fields().scalars();
  sink.Value(f.distance_cap_m);
  sink.Value(f.safety_step);
  sink.Value(f.safety_background);
  sink.Value(std::int32_t{0});  // The runs' sentinel's first layer (of no meaning).
  sink.Value(static_cast<std::uint32_t>(kTileColumns));
  sink.Value(surface_total);
  sink.Value(run_total);
  sink.Value(value_total);
}

void WriteHeader(binary_file::Sink& sink, const TerrainModel& model) {
  std::uint64_t runs = 0;
  for (const TerrainFields::Chunk& chunk : model.fields().chunks()) {
    runs += chunk->intervals.size() - 1;  // The sentinel aside.
  }
  WriteHeaderWith(sink, model, model.surfaces().surface_count(), runs, model.fields().cell_count());
}

bool ReadHeader(binary_file::Reader& reader, Header* h, std::string* problem) {
  model_parts::Payload& p = h->payload;
  std::uint32_t tile_columns = 0;
  if (!binary_file::ReadFields(reader, &p.config, problem) ||
      !binary_file::ReadFields(reader, &p.summary, problem) ||
      !model_parts::ReadGeometry(reader, &p.surface_geometry) ||
      !reader.Value(&p.fields.distance_cap_m) || !reader.Value(&p.fields.safety_step) ||
      !reader.Value(&p.fields.safety_background) || !reader.Value(&h->sentinel_layer) ||
      !reader.Value(&tile_columns) || !reader.Value(&h->surface_total) ||
      !reader.Value(&h->run_total) || !reader.Value(&h->value_total)) {
    return false;
  }
  p.fields.geometry = p.surface_geometry;
  if (tile_columns != kTileColumns) {
    *problem = "its tiles are " + std::to_string(tile_columns) + " columns wide, not " +
               std::to_string(kTileColumns);
    return false;
  }
  return true;
}

// One tile's sections, checked against its block, with cursors for reading it column by
// column in its own order.
struct TileReader {
  const char* surface_counts = nullptr;
  const char* surfaces = nullptr;
  const char* run_counts = nullptr;
  const char* runs = nullptr;
  const char* distance = nullptr;
  const char* safety = nullptr;
  std::uint64_t surface_total = 0, run_total = 0, value_total = 0;
  std::uint64_t column = 0, surface = 0, run = 0, value = 0;  // Cursors.

  // Empty when `bytes` fit `columns`; else why not.
  std::string Open(std::string_view bytes, std::size_t columns) {
    const auto take = [&](std::uint64_t n, const char** at) {
      if (n > bytes.size()) return false;
      *at = bytes.data();
      bytes.remove_prefix(n);
      return true;
    };
    const auto sum = [columns](const char* counts) {
      std::uint64_t total = 0;
      for (std::size_t c = 0; c < columns; ++c) {
        total += Decode<std::uint32_t>(counts + c * kCountBytes);
      }
      return total;
    };
    if (!take(columns * kCountBytes, &surface_counts)) return "ends in its surface counts";
    surface_total = sum(surface_counts);
    if (surface_total > bytes.size() / kSurfaceRecordBytes ||
        !take(surface_total * kSurfaceRecordBytes, &surfaces)) {
      return "ends in its surfaces";
    }
    if (!take(columns * kCountBytes, &run_counts)) return "ends in its run counts";
    run_total = sum(run_counts);
    if (run_total > bytes.size() / kRunBytes || !take(run_total * kRunBytes, &runs)) {
      return "ends in its runs of layers";
    }
    for (std::uint64_t k = 0; k < run_total; ++k) {
      value_total += Decode<std::uint32_t>(runs + k * kRunBytes + 4);
    }
    if (bytes.size() != value_total * kValueBytes) {
      return "holds " + std::to_string(bytes.size()) + " bytes of values for " +
             std::to_string(value_total) + " layers";
    }
    distance = bytes.data();
    safety = bytes.data() + value_total * sizeof(std::int16_t);
    return {};
  }

  // Appends the next column's surfaces and fields, with their offsets, to `surfaces_out` and
  // `fields_out`; false for a bad surface record. The values of a column's runs lie together:
  // they are copied at once.
  bool NextColumn(ColumnSurfaces* surfaces_out, TerrainFields::Runs* fields_out) {
    std::vector<ColumnSurface>& out = surfaces_out->surfaces;
    surfaces_out->column_begin.push_back(static_cast<std::uint32_t>(out.size()));
    const auto surfaces_here = Decode<std::uint32_t>(surface_counts + column * kCountBytes);
    const std::size_t first_surface = out.size();
    out.resize(first_surface + surfaces_here);
    for (std::uint32_t i = 0; i < surfaces_here; ++i, ++surface) {
      if (!model_parts::DecodeSurface(surfaces + surface * kSurfaceRecordBytes,
                                      &out[first_surface + i])) {
        return false;
      }
    }
    TerrainFields::Runs& f = *fields_out;
    f.column_begin.push_back(static_cast<std::uint32_t>(f.intervals.size()));
    const auto runs_here = Decode<std::uint32_t>(run_counts + column * kCountBytes);
    const std::size_t first_value = f.distance.size();
    std::uint64_t layers_here = 0;
    for (std::uint32_t k = 0; k < runs_here; ++k, ++run) {
      const char* at = runs + run * kRunBytes;
      f.intervals.push_back(
          {Decode<std::int32_t>(at), static_cast<std::uint32_t>(first_value + layers_here)});
      layers_here += Decode<std::uint32_t>(at + 4);
    }
    // A chunk's arrays may still be empty, their data null, which memcpy may not be given.
    if (layers_here > 0) {
      f.distance.resize(first_value + layers_here);
      f.safety.resize(first_value + layers_here);
      std::memcpy(f.distance.data() + first_value, distance + value * sizeof(std::int16_t),
                  layers_here * sizeof(std::int16_t));
      std::memcpy(f.safety.data() + first_value, safety + value * sizeof(std::uint16_t),
                  layers_here * sizeof(std::uint16_t));
    }
    value += layers_here;
    ++column;
    return true;
  }
};

// A tile taken from a model in memory (HeldTiles): what its block of that model holds.
struct HeldTile {
  std::uint64_t surface_total = 0, run_total = 0, value_total = 0;

  HeldTile(const TerrainModel& model, const Block& block) {
    const ColumnSurfaces& s = *model.surfaces().chunks()[ChunkOf(block)];
    const TerrainFields::Runs& f = *model.fields().chunks()[ChunkOf(block)];
    // A block's columns of one grid row lie together.
    for (int y = block.y0; y < block.y1; ++y) {
      const std::int64_t first = ColumnInChunk(model.grid(), block.x0, y);
      const std::int64_t end = ColumnInChunk(model.grid(), block.x1, y);
      surface_total += s.column_begin[end] - s.column_begin[first];
      run_total += f.column_begin[end] - f.column_begin[first];
      value_total +=
          f.intervals[f.column_begin[end]].offset - f.intervals[f.column_begin[first]].offset;
    }
  }
};

}  // namespace

std::size_t TileCount(const GridGeometry& geometry) {
  return std::size_t(BlocksAlong(geometry.size.x())) * std::size_t(BlocksAlong(geometry.size.y()));
}

TiledModel CutModel(const TerrainModel& model) {
  std::vector<std::size_t> all(TileCount(model.grid()));
  std::iota(all.begin(), all.end(), std::size_t{0});
  return CutModelTiles(model, all);
}

std::vector<std::size_t> TilesTouching(const GridGeometry& geometry, const CellBox& columns) {
  std::vector<std::size_t> tiles;
  const int blocks_x = BlocksAlong(geometry.size.x());
  const int x0 = std::max(columns.min.x(), 0);
  const int y0 = std::max(columns.min.y(), 0);
  const int x1 = std::min(columns.max.x(), geometry.size.x() - 1);
  const int y1 = std::min(columns.max.y(), geometry.size.y() - 1);
  if (x1 < x0 || y1 < y0) return tiles;
  for (int by = y0 / kTileColumns; by <= y1 / kTileColumns; ++by) {
    for (int bx = x0 / kTileColumns; bx <= x1 / kTileColumns; ++bx) {
      tiles.push_back(std::size_t(by) * blocks_x + std::size_t(bx));
    }
  }
  return tiles;
}

CellBox TileColumns(const GridGeometry& geometry, std::size_t tile) {
  const Block block = BlockOf(geometry, tile);
  return {{block.x0, block.y0, 0}, {block.x1 - 1, block.y1 - 1, geometry.size.z() - 1}};
}

TiledModel CutModelTiles(const TerrainModel& model, std::span<const std::size_t> which) {
  TiledModel tiled;
  binary_file::Sink sink(&tiled.header);
  binary_file::WriteFrame(sink, kTiledModelKind,
                          [&model](binary_file::Sink& s) { WriteHeader(s, model); });
  tiled.tiles.reserve(which.size());
  for (const std::size_t t : which) tiled.tiles.push_back(CutTile(model, BlockOf(model.grid(), t)));
  return tiled;
}

namespace {

// The header `bytes` hold; kMapLoadFailed naming `name` when they hold none.
Expected<Header> ParseHeader(std::string_view bytes, const std::string& name) {
  Header header;
  binary_file::MemorySource source(bytes);
  if (Status read = binary_file::ReadFrame(source, bytes.size(), kTiledModelKind, name,
                                           [&header](binary_file::Reader& r, std::string* problem) {
                                             return ReadHeader(r, &header, problem);
                                           });
      !read) {
    return read.error();
  }
  return header;
}

// JoinModel; with `window` (may be null) only the tiles it marks are read, and every other
// column is left empty (JoinModelWindow).
Expected<std::shared_ptr<const TerrainModel>> JoinTiles(
    std::string_view header_bytes, std::size_t tile_count, std::uint64_t tile_bytes,
    const TileSource& source, const std::string& name, const HeldTiles* held,
    const std::vector<bool>* window) {
  const auto fail = [&name](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, "tiled model " + name + " " + what};
  };
  Expected<Header> parsed = ParseHeader(header_bytes, name);
  if (!parsed) return parsed.error();
  const Header& header = *parsed;
  const model_parts::Payload& p = header.payload;
  const GridGeometry& g = p.surface_geometry;
  if (tile_count != TileCount(g)) {
    return fail("has " + std::to_string(tile_count) + " tiles; its grid of " +
                std::to_string(g.size.x()) + " × " + std::to_string(g.size.y()) +
                " columns needs " + std::to_string(TileCount(g)));
  }
  constexpr std::uint64_t kMaxOffset = std::numeric_limits<std::uint32_t>::max();
  if (header.surface_total > kMaxOffset || header.run_total >= kMaxOffset ||
      header.value_total > kMaxOffset) {
    return fail("holds more surfaces, runs or layers than a model can index");
  }
  // Nothing is allocated beyond what the tiles' bytes can hold; the tiles are held to the
  // header's totals below.
  if (window == nullptr && (header.surface_total > tile_bytes / kSurfaceRecordBytes ||
                            header.run_total > tile_bytes / kRunBytes ||
                            header.value_total > tile_bytes / kValueBytes)) {
    return fail("counts more surfaces, runs or layers than its " + std::to_string(tile_bytes) +
                " bytes of tiles can hold");
  }
  const TerrainModel* held_model = held != nullptr && held->model != nullptr && held->same &&
                                           held->model->grid().size.head<2>() == g.size.head<2>()
                                       ? held->model
                                       : nullptr;
  std::vector<SurfaceMap::Chunk> surface_chunks;
  std::vector<TerrainFields::Chunk> field_chunks;
  // The chunks of a window's rows that hold no tile of it: all empty, one pair of them shared
  // (the last chunk's rows may be fewer: a pair of its own).
  SurfaceMap::Chunk empty_surfaces;
  TerrainFields::Chunk empty_fields;
  const int blocks_x = BlocksAlong(g.size.x());
  std::vector<std::string> row(blocks_x);
  std::vector<TileReader> readers(blocks_x);
  // Whether each tile of the row is the held model's (its block is then taken from it).
  std::vector<bool> from_held(blocks_x, false);
  std::vector<bool> in_window(blocks_x, true);  // Outside a window: empty columns.
  std::uint64_t surfaces = 0, runs = 0, values = 0, bytes_read = 0;
  for (int k = 0; k < ChunkCount(g); ++k) {
    const int y0 = k * kChunkRows;
    // What this row's tiles hold, so that its chunk is allocated once.
    std::uint64_t row_surfaces = 0, row_runs = 0, row_values = 0;
    for (int bx = 0; bx < blocks_x; ++bx) {
      const std::size_t t = std::size_t(k) * blocks_x + bx;
      in_window[bx] = window == nullptr || (*window)[t];
      from_held[bx] = in_window[bx] && held_model != nullptr && held->same(t);
      if (!in_window[bx]) continue;
      if (from_held[bx]) {
        const HeldTile tile(*held_model, BlockOf(g, t));
        row_surfaces += tile.surface_total;
        row_runs += tile.run_total;
        row_values += tile.value_total;
      } else {
        Expected<std::string> bytes = source(t);
        if (!bytes) return bytes.error();
        bytes_read += bytes->size();
        if (bytes_read > tile_bytes) {
          return fail("tile " + std::to_string(t) + " goes past the " + std::to_string(tile_bytes) +
                      " bytes its tiles were said to hold");
        }
        row[bx] = std::move(bytes).value();
        readers[bx] = TileReader{};
        if (std::string why = readers[bx].Open(row[bx], BlockOf(g, t).columns()); !why.empty()) {
          return fail("tile " + std::to_string(t) + " " + why);
        }
        row_surfaces += readers[bx].surface_total;
        row_runs += readers[bx].run_total;
        row_values += readers[bx].value_total;
      }
      if (surfaces + row_surfaces > header.surface_total || runs + row_runs > header.run_total ||
          values + row_values > header.value_total) {
        return fail("tile " + std::to_string(t) + " holds more than its header counts");
      }
    }
    surfaces += row_surfaces;
    runs += row_runs;
    values += row_values;
    const std::int64_t columns = std::int64_t{g.size.x()} * ChunkRowCount(g, k);
    if (std::find(from_held.begin(), from_held.end(), false) == from_held.end()) {
      // Every tile of the row is the held model's: so is its chunk, shared.
      surface_chunks.push_back(held_model->surfaces().chunks()[k]);
      field_chunks.push_back(held_model->fields().chunks()[k]);
      continue;
    }
    if (std::find(in_window.begin(), in_window.end(), true) == in_window.end()) {
      if (empty_surfaces == nullptr || std::ssize(empty_surfaces->column_begin) != columns + 1) {
        ColumnSurfaces none;
        none.column_begin.assign(columns + 1, 0);
        empty_surfaces = std::make_shared<const ColumnSurfaces>(std::move(none));
        TerrainFields::Runs no_runs;
        no_runs.column_begin.assign(columns + 1, 0);
        no_runs.intervals.push_back({0, 0});
        empty_fields = std::make_shared<const TerrainFields::Runs>(std::move(no_runs));
      }
      surface_chunks.push_back(empty_surfaces);
      field_chunks.push_back(empty_fields);
      continue;
    }
    ColumnSurfaces chunk_surfaces;
    chunk_surfaces.column_begin.reserve(columns + 1);
    chunk_surfaces.surfaces.reserve(row_surfaces);
    TerrainFields::Runs chunk_fields;
    chunk_fields.column_begin.reserve(columns + 1);
    chunk_fields.intervals.reserve(row_runs + 1);
    chunk_fields.distance.reserve(row_values);
    chunk_fields.safety.reserve(row_values);
    for (int y = y0; y < y0 + ChunkRowCount(g, k); ++y) {
      for (int x = 0; x < g.size.x();) {
        if (from_held[x / kTileColumns]) {
          // The held blocks next to each other in this row: one run of the held chunk's columns.
          const int end = EndOfBlockRun(from_held, x, g.size.x());
          const std::int64_t first = ColumnInChunk(g, x, y);
          const std::int64_t last = first + (end - x);
          internal::AppendColumns(*held_model->surfaces().chunks()[k], first, last,
                                  &chunk_surfaces);
          internal::AppendColumns(*held_model->fields().chunks()[k], first, last, &chunk_fields);
          x = end;
          continue;
        }
        if (!in_window[x / kTileColumns]) {
          // The blocks outside the window next to each other in this row: empty columns.
          const int end = EndOfBlockRun(in_window, x, g.size.x());
          chunk_surfaces.column_begin.insert(
              chunk_surfaces.column_begin.end(), end - x,
              static_cast<std::uint32_t>(chunk_surfaces.surfaces.size()));
          chunk_fields.column_begin.insert(
              chunk_fields.column_begin.end(), end - x,
              static_cast<std::uint32_t>(chunk_fields.intervals.size()));
          x = end;
          continue;
        }
        if (!readers[x / kTileColumns].NextColumn(&chunk_surfaces, &chunk_fields)) {
          return fail("tile " +
                      std::to_string(std::size_t(k) * blocks_x + std::size_t(x / kTileColumns)) +
                      " holds a surface with a bad valid flag");
        }
        ++x;
      }
    }
    internal::FinishColumns(&chunk_surfaces);
    internal::FinishColumns(&chunk_fields);
    surface_chunks.push_back(std::make_shared<const ColumnSurfaces>(std::move(chunk_surfaces)));
    field_chunks.push_back(std::make_shared<const TerrainFields::Runs>(std::move(chunk_fields)));
  }
  if (window == nullptr && (surfaces != header.surface_total || runs != header.run_total ||
                            values != header.value_total)) {
    return fail("holds fewer surfaces, runs or layers than its header counts");
  }
  return model_parts::BuildModelFromChunks(p, std::move(surface_chunks), std::move(field_chunks),
                                           held_model, "tiled model", name);
}

}  // namespace

Expected<std::shared_ptr<const TerrainModel>> JoinModel(
    std::string_view header, std::size_t tile_count, std::uint64_t tile_bytes,
    const TileSource& source, const std::string& name, const HeldTiles* held) {
  return JoinTiles(header, tile_count, tile_bytes, source, name, held, nullptr);
}

Expected<std::shared_ptr<const TerrainModel>> JoinModelWindow(std::string_view header,
                                                              std::span<const std::size_t> which,
                                                              const TileSource& source,
                                                              const std::string& name) {
  Expected<Header> parsed = ParseHeader(header, name);
  if (!parsed) return parsed.error();
  const std::size_t count = TileCount(parsed->payload.surface_geometry);
  std::vector<bool> window(count, false);
  for (const std::size_t t : which) {
    if (t >= count) {
      return Error{ErrorCode::kMapLoadFailed, "tiled model " + name + " has no tile " +
                                                  std::to_string(t) + " (it has " +
                                                  std::to_string(count) + ")"};
    }
    window[t] = true;
  }
  // The window's tiles are read first, so that the model reserves what they hold.
  std::vector<std::string> bytes(count);
  std::uint64_t total = 0;
  for (const std::size_t t : which) {
    Expected<std::string> tile = source(t);
    if (!tile) return tile.error();
    total += tile->size();
    bytes[t] = std::move(tile).value();
  }
  return JoinTiles(
      header, count, total,
      [&bytes](std::size_t t) -> Expected<std::string> { return std::move(bytes[t]); }, name,
      nullptr, &window);
}

Expected<TiledModelHeader> ReadTiledModelHeader(std::string_view header, const std::string& name) {
  Expected<Header> parsed = ParseHeader(header, name);
  if (!parsed) return parsed.error();
  return TiledModelHeader{parsed->payload.config, parsed->payload.summary,
                          parsed->payload.surface_geometry};
}

Expected<TiledModel> CutEditedTiles(const TerrainModel& edited, const TerrainModel& base,
                                    std::string_view base_header,
                                    std::span<const std::size_t> which) {
  Expected<Header> totals = ParseHeader(base_header, "of the base");
  if (!totals) return totals.error();
  const GridGeometry& g = edited.grid();
  for (const std::size_t t : which) {
    const HeldTile now(edited, BlockOf(g, t));
    const HeldTile before(base, BlockOf(g, t));
    totals->surface_total += now.surface_total - before.surface_total;
    totals->run_total += now.run_total - before.run_total;
    totals->value_total += now.value_total - before.value_total;
  }
  TiledModel tiled;
  binary_file::Sink sink(&tiled.header);
  binary_file::WriteFrame(sink, kTiledModelKind, [&](binary_file::Sink& out) {
    WriteHeaderWith(out, edited, totals->surface_total, totals->run_total, totals->value_total);
  });
  tiled.tiles.reserve(which.size());
  for (const std::size_t t : which) tiled.tiles.push_back(CutTile(edited, BlockOf(g, t)));
  return tiled;
}

Expected<std::shared_ptr<const TerrainModel>> JoinModel(std::string_view header,
                                                        std::span<const std::string_view> tiles,
                                                        const std::string& name) {
  std::uint64_t bytes = 0;
  for (const std::string_view tile : tiles) bytes += tile.size();
  return JoinModel(
      header, tiles.size(), bytes,
      [tiles](std::size_t t) -> Expected<std::string> { return std::string(tiles[t]); }, name);
}

std::vector<std::string> CutCloud(const PointCloud& cloud, const GridGeometry& geometry) {
  std::vector<std::size_t> all(TileCount(geometry));
  std::iota(all.begin(), all.end(), std::size_t{0});
  return CutCloudTiles(cloud, geometry, all);
}

std::vector<std::string> CutCloudTiles(const PointCloud& cloud, const GridGeometry& geometry,
                                       std::span<const std::size_t> which) {
  // Each grid tile's place among `which`, or kSkipped.
  constexpr std::uint32_t kSkipped = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> slot_of_tile(TileCount(geometry), kSkipped);
  // The columns the tiles span: an edit's few tiles lie in a small box, and a point outside
  // it is passed over with four comparisons instead of finding its tile (on a 400 m site,
  // cutting a scan's tiles took 0.3 s doing that for every point).
  Block span{geometry.size.x(), 0, geometry.size.y(), 0};
  for (std::size_t k = 0; k < which.size(); ++k) {
    slot_of_tile[which[k]] = static_cast<std::uint32_t>(k);
    const Block block = BlockOf(geometry, which[k]);
    span = {std::min(span.x0, block.x0), std::max(span.x1, block.x1), std::min(span.y0, block.y0),
            std::max(span.y1, block.y1)};
  }
  std::vector<std::string> tiles(which.size());
  if (which.empty()) return tiles;
  const int blocks_x = BlocksAlong(geometry.size.x());
  const auto column = [&](double coordinate, int axis) {
    const double cell = std::floor((coordinate - geometry.origin_m[axis]) / geometry.resolution_m);
    return static_cast<int>(std::clamp(cell, 0.0, double(geometry.size[axis] - 1)));
  };
  // The box in metres, a column wider on each side than the span (so that rounding never
  // passes over a point inside it) and open where the span reaches the grid's edge (points
  // past it belong to the edge's columns).
  constexpr double kOpen = std::numeric_limits<double>::infinity();
  const auto low = [&](int first, int axis) {
    return first == 0 ? -kOpen : geometry.origin_m[axis] + (first - 1) * geometry.resolution_m;
  };
  const auto high = [&](int end, int axis) {
    return end == geometry.size[axis] ? kOpen
                                      : geometry.origin_m[axis] + (end + 1) * geometry.resolution_m;
  };
  const double x_low = low(span.x0, 0), x_high = high(span.x1, 0);
  const double y_low = low(span.y0, 1), y_high = high(span.y1, 1);
  const auto slot_of = [&](const Eigen::Vector3f& point) {
    if (!(point.x() >= x_low && point.x() <= x_high && point.y() >= y_low && point.y() <= y_high)) {
      return kSkipped;
    }
    return slot_of_tile[std::size_t(column(point.y(), 1) / kTileColumns) * blocks_x +
                        std::size_t(column(point.x(), 0) / kTileColumns)];
  };
  // Two passes: the points of each tile counted, then every tile filled at its size
  // (appending point by point into growing strings took three times as long).
  std::vector<std::size_t> points_in(tiles.size(), 0);
  for (const Eigen::Vector3f& point : cloud) {
    if (const std::uint32_t slot = slot_of(point); slot != kSkipped) ++points_in[slot];
  }
  std::vector<std::size_t> filled(tiles.size(), 0);
  for (std::size_t t = 0; t < tiles.size(); ++t) tiles[t].resize(points_in[t] * kPointBytes);
  for (const Eigen::Vector3f& point : cloud) {
    const std::uint32_t slot = slot_of(point);
    if (slot == kSkipped) continue;
    std::memcpy(tiles[slot].data() + filled[slot], point.data(), kPointBytes);
    filled[slot] += kPointBytes;
  }
  return tiles;
}

namespace {

// Appends cloud tile `t` of the cloud `name` to `cloud`; kMapLoadFailed naming both when it
// is not a whole number of points.
Status AppendCloudTile(std::string_view tile, std::size_t t, const std::string& name,
                       PointCloud* cloud) {
  if (tile.size() % kPointBytes != 0) {
    return Error{ErrorCode::kMapLoadFailed, "tiled cloud " + name + " tile " + std::to_string(t) +
                                                " is not a whole number of points"};
  }
  const std::size_t first = cloud->size();
  cloud->resize(first + tile.size() / kPointBytes);
  std::memcpy(reinterpret_cast<char*>(cloud->data() + first), tile.data(), tile.size());
  return Status::Ok();
}

}  // namespace

Expected<PointCloud> JoinCloud(std::span<const std::string_view> tiles, const std::string& name) {
  std::size_t bytes = 0;
  for (const std::string_view tile : tiles) bytes += tile.size();
  PointCloud cloud;
  cloud.reserve(bytes / kPointBytes);
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    if (Status s = AppendCloudTile(tiles[t], t, name, &cloud); !s) return s.error();
  }
  return cloud;
}

Expected<PointCloud> JoinCloud(std::size_t tile_count, std::uint64_t tile_bytes,
                               const TileSource& source, const std::string& name) {
  PointCloud cloud;
  cloud.reserve(static_cast<std::size_t>(tile_bytes / kPointBytes));
  for (std::size_t t = 0; t < tile_count; ++t) {
    Expected<std::string> tile = source(t);
    if (!tile) return tile.error();
    if (Status s = AppendCloudTile(*tile, t, name, &cloud); !s) return s.error();
  }
  return cloud;
}

}  // namespace strata
