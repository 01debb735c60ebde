#include "strata/assessment/terrain_fields.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "column_chunks_internal.hpp"

namespace strata {
namespace {

Error Inconsistent(const std::string& what) {
  return Error{ErrorCode::kInvalidInput, "terrain fields are inconsistent: " + what};
}

template <typename Value>
double Interpolate(const double t[3], const bool clamped[3], const Value& value, double inv_r,
                   Eigen::Vector3d* gradient) {
  double v[8];
  for (int k = 0; k < 8; ++k) v[k] = value(k);
  const double tx = t[0], ty = t[1], tz = t[2];
  const double c00 = v[0] + tx * (v[1] - v[0]);
  const double c10 = v[2] + tx * (v[3] - v[2]);
  const double c01 = v[4] + tx * (v[5] - v[4]);
  const double c11 = v[6] + tx * (v[7] - v[6]);
  const double c0 = c00 + ty * (c10 - c00);
  const double c1 = c01 + ty * (c11 - c01);
  if (gradient != nullptr) {
    const double dx = (1.0 - tz) * ((1.0 - ty) * (v[1] - v[0]) + ty * (v[3] - v[2])) +
                      tz * ((1.0 - ty) * (v[5] - v[4]) + ty * (v[7] - v[6]));
    const double dy = (1.0 - tz) * (c10 - c00) + tz * (c11 - c01);
    const double dz = c1 - c0;
    *gradient = Eigen::Vector3d(clamped[0] ? 0.0 : dx * inv_r, clamped[1] ? 0.0 : dy * inv_r,
                                clamped[2] ? 0.0 : dz * inv_r);
  }
  return c0 + tz * (c1 - c0);
}

// Why `runs`, the fields of `columns` columns of a grid of `layers` layers, are inconsistent,
// or empty when they are not.
std::string Inconsistency(const TerrainFields::Runs& runs, std::int64_t columns, int layers) {
  if (static_cast<std::int64_t>(runs.column_begin.size()) != columns + 1 ||
      runs.column_begin.front() != 0 ||
      runs.column_begin.back() + std::size_t{1} != runs.intervals.size()) {
    return "column index does not match the grid and the intervals";
  }
  if (runs.distance.size() != runs.safety.size() ||
      runs.intervals.back().offset != runs.distance.size()) {
    return "value arrays do not match the intervals";
  }
  for (std::int64_t c = 0; c < columns; ++c) {
    const std::uint32_t begin = runs.column_begin[c], end = runs.column_begin[c + 1];
    // Past the last entry, intervals[k + 1] below would read beyond the intervals.
    if (end < begin || end > runs.column_begin.back()) return "column index is not monotone";
    std::int64_t previous_end = -1;
    for (std::uint32_t k = begin; k < end; ++k) {
      const TerrainFields::Interval& interval = runs.intervals[k];
      const std::int64_t count =
          std::int64_t{runs.intervals[k + 1].offset} - std::int64_t{interval.offset};
      if (count < 1 || interval.first_layer <= previous_end ||
          std::int64_t{interval.first_layer} + count > layers) {
        return "an interval is empty, unsorted or outside the grid's layers";
      }
      previous_end = interval.first_layer + count - 1;
    }
  }
  return {};
}

// Why `scalars` cannot be fields' scalars, or empty.
std::string Inconsistency(const TerrainFields::Scalars& scalars) {
  const GridGeometry& g = scalars.geometry;
  if (!(g.resolution_m > 0) || (g.size.array() < 1).any()) return "empty grid";
  if (!(scalars.distance_cap_m > 0 && scalars.distance_cap_m <= TerrainFields::kMaxDistanceM)) {
    return "distance cap out of (0, 32] m";
  }
  if (!(std::isfinite(scalars.safety_step) && scalars.safety_step >= 0) ||
      !(std::isfinite(scalars.safety_background) && scalars.safety_background >= 0)) {
    return "safety step or background not finite and >= 0";
  }
  return {};
}

}  // namespace

Expected<TerrainFields> TerrainFields::FromParts(const Parts& parts) {
  const GridGeometry& g = parts.geometry;
  if (std::string why = Inconsistency(static_cast<const Scalars&>(parts)); !why.empty()) {
    return Inconsistent(why);
  }
  if (std::string why =
          Inconsistency(static_cast<const Runs&>(parts), g.LayerCellCount(), g.size.z());
      !why.empty()) {
    return Inconsistent(why);
  }
  TerrainFields fields;
  fields.scalars_ = parts;
  fields.cell_count_ = parts.distance.size();
  fields.chunks_.reserve(ChunkCount(g));
  const std::int64_t nx = g.size.x();
  for (int k = 0; k < ChunkCount(g); ++k) {
    const std::int64_t first = nx * k * kChunkRows;
    const std::int64_t end = first + nx * ChunkRowCount(g, k);
    Runs chunk;
    internal::Reserve(internal::SizeOfColumns(parts, first, end), &chunk);
    internal::AppendColumns(parts, first, end, &chunk);
    internal::FinishColumns(&chunk);
    fields.chunks_.push_back(std::make_shared<const Runs>(std::move(chunk)));
  }
  return fields;
}

Expected<TerrainFields> TerrainFields::FromChunks(const Scalars& scalars, std::vector<Chunk> chunks,
                                                  const TerrainFields* checked) {
  if (std::string why = Inconsistency(scalars); !why.empty()) return Inconsistent(why);
  const GridGeometry& g = scalars.geometry;
  if (static_cast<int>(chunks.size()) != ChunkCount(g)) {
    return Inconsistent("the chunks do not cover the grid's rows");
  }
  const bool same_grid = checked != nullptr && checked->geometry().size == g.size;
  TerrainFields fields;
  fields.scalars_ = scalars;
  for (int k = 0; k < ChunkCount(g); ++k) {
    if (chunks[k] == nullptr) return Inconsistent("a chunk is missing");
    fields.cell_count_ += chunks[k]->distance.size();
    if (same_grid && checked->chunks_[k] == chunks[k]) continue;
    if (std::string why =
            Inconsistency(*chunks[k], g.size.x() * std::int64_t{ChunkRowCount(g, k)}, g.size.z());
        !why.empty()) {
      return Inconsistent(why);
    }
  }
  if (fields.cell_count_ > std::numeric_limits<std::uint32_t>::max()) {
    return Inconsistent("more than 2^32 stored cells");
  }
  fields.chunks_ = std::move(chunks);
  return fields;
}

TerrainFields::Parts TerrainFields::ToParts() const {
  Parts parts;
  static_cast<Scalars&>(parts) = scalars_;
  for (const Chunk& chunk : chunks_) {
    internal::AppendColumns(*chunk, 0, std::ssize(chunk->column_begin) - 1, &parts);
  }
  internal::FinishColumns(&parts);
  return parts;
}

namespace {

// The value indices of cells (column, iz) and (column, iz + 1) of `runs` (column: its index
// there), from one pass over the column's intervals, into *at_iz and *above (-1 where not
// stored).
void FindPair(const TerrainFields::Runs& runs, std::int64_t column, int iz, std::int64_t* at_iz,
              std::int64_t* above) {
  *at_iz = -1;
  *above = -1;
  const std::uint32_t end = runs.column_begin[column + 1];
  for (std::uint32_t k = runs.column_begin[column]; k < end; ++k) {
    const TerrainFields::Interval& interval = runs.intervals[k];
    if (iz + 1 < interval.first_layer) break;
    const std::int64_t count =
        std::int64_t{runs.intervals[k + 1].offset} - std::int64_t{interval.offset};
    const std::int64_t layer = iz - std::int64_t{interval.first_layer};
    if (layer >= 0 && layer < count) *at_iz = std::int64_t{interval.offset} + layer;
    if (layer + 1 >= 0 && layer + 1 < count) *above = std::int64_t{interval.offset} + layer + 1;
  }
}

// Where p falls along axis a of g (inv_r = 1 / its resolution): the lower cell centre i of its
// pair, its weight t towards the upper one, and whether p was clamped onto the hull of centres.
struct AxisCell {
  int i;
  double t;
  bool clamped;
};
// TerrainFields::BlockKey of the block whose lower cell centre is `cell`.
std::int64_t BlockKeyOf(const GridGeometry& g, const int cell[3]) {
  return cell[0] + std::int64_t{g.size.x()} * (cell[1] + std::int64_t{g.size.y()} * cell[2]);
}

AxisCell LocateOnAxis(const GridGeometry& g, double inv_r, const Eigen::Vector3d& p, int a) {
  // u is the position in "centre coordinates": cell centre i sits at u = i.
  double u = (p[a] - g.origin_m[a]) * inv_r - 0.5;
  const int n = g.size[a];
  bool clamped = false;
  if (!(u >= 0.0)) {  // Also catches NaN, which would otherwise index out of range.
    u = 0.0;
    clamped = true;
  } else if (u > n - 1) {
    u = n - 1;
    clamped = true;
  }
  int i = static_cast<int>(u);
  // The last centre belongs to the pair (n-2, n-1) with t = 1; a one-cell axis has no pair.
  if (i > n - 2) i = n > 1 ? n - 2 : 0;
  return {i, u - i, clamped};
}

}  // namespace

// The eight corners of a trilinear sample: where their values are stored (runs == nullptr
// outside the band) and the weights.
struct TerrainFields::Corners {
  CellRef at[8];  // (x, y, z) bits: corner k is at offset (k & 1, k >> 1 & 1, k >> 2).
  double t[3];
  bool clamped[3];
  int cell[3];  // The block's lower cell centre (TerrainFields::BlockKey).
};

TerrainFields::Corners TerrainFields::Locate(const Eigen::Vector3d& p) const {
  const GridGeometry& g = scalars_.geometry;
  Corners c;
  const int* i = c.cell;
  int step[3];
  const double inv_r = 1.0 / g.resolution_m;
  for (int a = 0; a < 3; ++a) {
    const AxisCell cell = LocateOnAxis(g, inv_r, p, a);
    c.cell[a] = cell.i;
    c.t[a] = cell.t;
    c.clamped[a] = cell.clamped;
    step[a] = g.size[a] > 1 ? 1 : 0;
  }
  for (int k = 0; k < 4; ++k) {
    const int ix = i[0] + (k & 1) * step[0], iy = i[1] + (k >> 1) * step[1];
    const Runs* runs = chunks_[iy / kChunkRows].get();
    const std::int64_t column = ix + std::int64_t{g.size.x()} * (iy % kChunkRows);
    std::int64_t at_iz = -1, above = -1;
    FindPair(*runs, column, i[2], &at_iz, &above);
    c.at[k] = at_iz < 0 ? CellRef{} : CellRef{runs, at_iz};
    // A one-layer grid: both at layer 0.
    if (step[2] == 0) {
      c.at[k + 4] = c.at[k];
    } else {
      c.at[k + 4] = above < 0 ? CellRef{} : CellRef{runs, above};
    }
  }
  return c;
}

TerrainFields::CellRef TerrainFields::FindCell(const Eigen::Vector3i& cell) const {
  const GridGeometry& g = scalars_.geometry;
  if (!g.Contains(cell)) return {};
  const Runs* runs = chunks_[cell.y() / kChunkRows].get();
  std::int64_t at_cell = -1, above = -1;
  FindPair(*runs, cell.x() + std::int64_t{g.size.x()} * (cell.y() % kChunkRows), cell.z(), &at_cell,
           &above);
  return at_cell < 0 ? CellRef{} : CellRef{runs, at_cell};
}

double TerrainFields::Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  const Corners c = Locate(p);
  return Interpolate(
      c.t, c.clamped, [&](int k) { return DistanceValue(c.at[k]); },
      1.0 / scalars_.geometry.resolution_m, gradient);
}

double TerrainFields::SafetyPenalty(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  const Corners c = Locate(p);
  return Interpolate(
      c.t, c.clamped, [&](int k) { return SafetyValue(c.at[k]); },
      1.0 / scalars_.geometry.resolution_m, gradient);
}

void TerrainFields::Sample(const Eigen::Vector3d& p, FieldSample* sample, FieldBlock* block) const {
  const GridGeometry& g = scalars_.geometry;
  const Corners c = Locate(p);
  const double inv_r = 1.0 / g.resolution_m;
  sample->distance_m = Interpolate(
      c.t, c.clamped, [&](int k) { return DistanceValue(c.at[k]); }, inv_r,
      &sample->distance_gradient);
  sample->safety = Interpolate(
      c.t, c.clamped, [&](int k) { return SafetyValue(c.at[k]); }, inv_r, &sample->safety_gradient);
  if (block == nullptr) return;
  block->key = BlockKeyOf(g, c.cell);
  block->max_safety = SafetyValue(c.at[0]);
  block->min_distance = DistanceValue(c.at[0]);
  for (int k = 1; k < 8; ++k) {
    block->max_safety = std::max(block->max_safety, SafetyValue(c.at[k]));
    block->min_distance = std::min(block->min_distance, DistanceValue(c.at[k]));
  }
}

TerrainFields::DistanceBounds TerrainFields::DistanceBoundsIn(
    const Eigen::AlignedBox3d& box) const {
  const GridGeometry& g = scalars_.geometry;
  const double inv_r = 1.0 / g.resolution_m;
  // The corners of the blocks of the box's two extreme points and of every block between.
  int low[3], count[3];
  for (int a = 0; a < 3; ++a) {
    low[a] = LocateOnAxis(g, inv_r, box.min(), a).i;
    const int high = std::min(LocateOnAxis(g, inv_r, box.max(), a).i + 1, g.size[a] - 1);
    count[a] = high - low[a] + 1;
  }
  // Values x fastest; a column's layers found once each.
  std::vector<double> value(static_cast<std::size_t>(count[0]) * count[1] * count[2]);
  const auto at = [&](int x, int y, int z) -> double& {
    return value[x +
                 static_cast<std::size_t>(count[0]) * (y + static_cast<std::size_t>(count[1]) * z)];
  };
  for (int z = 0; z < count[2]; ++z) {
    for (int y = 0; y < count[1]; ++y) {
      for (int x = 0; x < count[0]; ++x) {
        at(x, y, z) = DistanceValue(FindCell({low[0] + x, low[1] + y, low[2] + z}));
      }
    }
  }
  DistanceBounds bounds{*std::min_element(value.begin(), value.end()), 0};
  double largest[3] = {0, 0, 0};  // The largest neighbour difference along each axis.
  for (int z = 0; z < count[2]; ++z) {
    for (int y = 0; y < count[1]; ++y) {
      for (int x = 0; x < count[0]; ++x) {
        const double v = at(x, y, z);
        if (x + 1 < count[0]) largest[0] = std::max(largest[0], std::abs(at(x + 1, y, z) - v));
        if (y + 1 < count[1]) largest[1] = std::max(largest[1], std::abs(at(x, y + 1, z) - v));
        if (z + 1 < count[2]) largest[2] = std::max(largest[2], std::abs(at(x, y, z + 1) - v));
      }
    }
  }
  bounds.max_slope = Eigen::Vector3d(largest[0], largest[1], largest[2]).norm() * inv_r;
  return bounds;
}

std::int64_t TerrainFields::BlockKey(const Eigen::Vector3d& p) const {
  const GridGeometry& g = scalars_.geometry;
  const double inv_r = 1.0 / g.resolution_m;
  int cell[3];
  for (int a = 0; a < 3; ++a) cell[a] = LocateOnAxis(g, inv_r, p, a).i;
  return BlockKeyOf(g, cell);
}

std::optional<double> TerrainFields::DistanceAt(const Eigen::Vector3i& cell) const {
  const CellRef at = FindCell(cell);
  if (at.runs == nullptr) return std::nullopt;
  return DistanceValue(at);
}

std::optional<double> TerrainFields::SafetyAt(const Eigen::Vector3i& cell) const {
  const CellRef at = FindCell(cell);
  if (at.runs == nullptr) return std::nullopt;
  return SafetyValue(at);
}

namespace {

std::size_t ChunkBytes(const TerrainFields::Runs& chunk) {
  return chunk.column_begin.capacity() * sizeof(std::uint32_t) +
         chunk.intervals.capacity() * sizeof(TerrainFields::Interval) +
         chunk.distance.capacity() * sizeof(std::int16_t) +
         chunk.safety.capacity() * sizeof(std::uint16_t);
}

}  // namespace

std::size_t TerrainFields::MemoryBytes() const {
  std::size_t bytes = chunks_.capacity() * sizeof(Chunk);
  for (const Chunk& chunk : chunks_) bytes += ChunkBytes(*chunk);
  return bytes;
}

std::size_t TerrainFields::MemoryBytesBeyond(const TerrainFields& other) const {
  if (other.chunks_.size() != chunks_.size()) return MemoryBytes();
  std::size_t bytes = chunks_.capacity() * sizeof(Chunk);
  for (std::size_t k = 0; k < chunks_.size(); ++k) {
    if (chunks_[k] != other.chunks_[k]) bytes += ChunkBytes(*chunks_[k]);
  }
  return bytes;
}

}  // namespace strata
