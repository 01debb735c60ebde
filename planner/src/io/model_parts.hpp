#pragma once
// What a saved model and a tiled model share (saved_model.cpp, model_tiles.cpp): how a
// column surface and a grid become bytes and back, and a model made from its arrays.
// Internal to the planner library's io/.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "binary_file.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/status.hpp"

namespace strata::model_parts {

// Bytes per stored ColumnSurface and Interval (field by field, no padding).
inline constexpr std::size_t kSurfaceRecordBytes = 4 * 4 + 2 * 4 + 1;
inline constexpr std::size_t kIntervalRecordBytes = 4 + 4;

void EncodeSurface(const ColumnSurface& s, char* bytes);
// False when the record holds a `valid` flag other than 0 or 1.
bool DecodeSurface(const char* bytes, ColumnSurface* s);

void WriteGeometry(binary_file::Sink& sink, const GridGeometry& g);
// False when the bytes run out or the grid is not finite, positive and non-empty.
bool ReadGeometry(binary_file::Reader& reader, GridGeometry* g);

// A model's arrays as a file holds them.
struct Payload {
  AssessmentConfig config;
  AssessmentSummary summary;
  GridGeometry surface_geometry;
  std::vector<std::uint32_t> column_begin;
  std::vector<ColumnSurface> surfaces;
  TerrainFields::Parts fields;
};

// The model of `payload`, every part checked (kMapLoadFailed: "<noun> <name> is
// inconsistent: ...").
Expected<std::shared_ptr<const TerrainModel>> BuildModel(Payload payload, const std::string& noun,
                                                         const std::string& name);

// The model of `payload`'s parameters, summary and scalars (its arrays unused) and of the
// chunks of its surfaces and fields, checked as BuildModel checks, but for the chunks it shares
// with `checked` (may be null), which were checked when that model was made.
Expected<std::shared_ptr<const TerrainModel>> BuildModelFromChunks(
    const Payload& payload, std::vector<SurfaceMap::Chunk> surface_chunks,
    std::vector<TerrainFields::Chunk> field_chunks, const TerrainModel* checked,
    const std::string& noun, const std::string& name);

}  // namespace strata::model_parts
