#pragma once
// Building the chunks of a model's column arrays (SurfaceMap, TerrainFields; kChunkRows in
// grid.hpp) from the columns of other arrays: an edit's chunk from its base's chunk and the
// reassessed columns (map_edit.cpp), a joined chunk from a held model's and the tiles read
// (model_tiles.cpp). Internal to the planner library.

#include <cstdint>
#include <vector>

#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_fields.hpp"

namespace strata::internal {

/// Appends columns [first, end) of `from` (its column indices) to `out`, their offsets moved
/// to where their surfaces land. Finish `out` with FinishColumns.
inline void AppendColumns(const ColumnSurfaces& from, std::int64_t first, std::int64_t end,
                          ColumnSurfaces* out) {
  const std::uint32_t begin = from.column_begin[first];
  const auto shift = static_cast<std::uint32_t>(out->surfaces.size()) - begin;
  for (std::int64_t c = first; c < end; ++c) {
    out->column_begin.push_back(from.column_begin[c] + shift);
  }
  out->surfaces.insert(out->surfaces.end(), from.surfaces.begin() + begin,
                       from.surfaces.begin() + from.column_begin[end]);
}

/// Appends columns [first, end) of `from` to `out` (whose intervals hold no sentinel yet),
/// their offsets moved to where their intervals and values land. Finish `out` with
/// FinishColumns.
inline void AppendColumns(const TerrainFields::Runs& from, std::int64_t first, std::int64_t end,
                          TerrainFields::Runs* out) {
  const std::uint32_t run_begin = from.column_begin[first];
  const std::uint32_t run_end = from.column_begin[end];
  const auto run_shift = static_cast<std::uint32_t>(out->intervals.size()) - run_begin;
  for (std::int64_t c = first; c < end; ++c) {
    out->column_begin.push_back(from.column_begin[c] + run_shift);
  }
  const std::uint32_t value_begin = from.intervals[run_begin].offset;
  const std::uint32_t value_end = from.intervals[run_end].offset;
  const auto value_shift = static_cast<std::uint32_t>(out->distance.size()) - value_begin;
  for (std::uint32_t k = run_begin; k < run_end; ++k) {
    out->intervals.push_back(
        {from.intervals[k].first_layer, from.intervals[k].offset + value_shift});
  }
  out->distance.insert(out->distance.end(), from.distance.begin() + value_begin,
                       from.distance.begin() + value_end);
  out->safety.insert(out->safety.end(), from.safety.begin() + value_begin,
                     from.safety.begin() + value_end);
}

/// What columns [first, end) of some arrays hold, so that arrays built by AppendColumns are
/// allocated once (Reserve).
struct ColumnsSize {
  std::uint64_t columns = 0;
  std::uint64_t items = 0;   ///< Surfaces, or the fields' runs.
  std::uint64_t values = 0;  ///< The fields' stored cells (none for surfaces).
  ColumnsSize& operator+=(const ColumnsSize& other) {
    columns += other.columns;
    items += other.items;
    values += other.values;
    return *this;
  }
};
inline ColumnsSize SizeOfColumns(const ColumnSurfaces& from, std::int64_t first, std::int64_t end) {
  return {static_cast<std::uint64_t>(end - first),
          from.column_begin[end] - from.column_begin[first], 0};
}
inline ColumnsSize SizeOfColumns(const TerrainFields::Runs& from, std::int64_t first,
                                 std::int64_t end) {
  return {static_cast<std::uint64_t>(end - first),
          from.column_begin[end] - from.column_begin[first],
          from.intervals[from.column_begin[end]].offset -
              from.intervals[from.column_begin[first]].offset};
}
/// Room in `out` for `size` more (and FinishColumns's entries).
inline void Reserve(const ColumnsSize& size, ColumnSurfaces* out) {
  out->column_begin.reserve(out->column_begin.size() + size.columns + 1);
  out->surfaces.reserve(out->surfaces.size() + size.items);
}
inline void Reserve(const ColumnsSize& size, TerrainFields::Runs* out) {
  out->column_begin.reserve(out->column_begin.size() + size.columns + 1);
  out->intervals.reserve(out->intervals.size() + size.items + 1);
  out->distance.reserve(out->distance.size() + size.values);
  out->safety.reserve(out->safety.size() + size.values);
}

/// Ends arrays built by AppendColumns: the final offset (and the fields' sentinel).
inline void FinishColumns(ColumnSurfaces* out) {
  out->column_begin.push_back(static_cast<std::uint32_t>(out->surfaces.size()));
}
inline void FinishColumns(TerrainFields::Runs* out) {
  out->column_begin.push_back(static_cast<std::uint32_t>(out->intervals.size()));
  out->intervals.push_back({0, static_cast<std::uint32_t>(out->distance.size())});
}

}  // namespace strata::internal
