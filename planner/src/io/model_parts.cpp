#include "model_parts.hpp"

#include <cmath>
#include <utility>

namespace strata::model_parts {

using binary_file::Decode;
using binary_file::Encode;

void EncodeSurface(const ColumnSurface& s, char* bytes) {
  Encode(bytes, s.ground_z_m);
  Encode(bytes + 4, s.clearance_m);
  Encode(bytes + 8, s.tilt_rad);
  Encode(bytes + 12, s.plane_center_z_m);
  Encode(bytes + 16, s.top_layer);
  Encode(bytes + 20, s.bottom_layer);
  Encode(bytes + 24, static_cast<std::uint8_t>(s.valid));
}

bool DecodeSurface(const char* bytes, ColumnSurface* s) {
  s->ground_z_m = Decode<float>(bytes);
  s->clearance_m = Decode<float>(bytes + 4);
  s->tilt_rad = Decode<float>(bytes + 8);
  s->plane_center_z_m = Decode<float>(bytes + 12);
  s->top_layer = Decode<std::int32_t>(bytes + 16);
  s->bottom_layer = Decode<std::int32_t>(bytes + 20);
  const auto valid = Decode<std::uint8_t>(bytes + 24);
  s->valid = valid != 0;
  return valid <= 1;
}

void WriteGeometry(binary_file::Sink& sink, const GridGeometry& g) {
  for (int a = 0; a < 3; ++a) sink.Value(g.origin_m[a]);
  sink.Value(g.resolution_m);
  for (int a = 0; a < 3; ++a) sink.Value(static_cast<std::int32_t>(g.size[a]));
}

bool ReadGeometry(binary_file::Reader& reader, GridGeometry* g) {
  for (int a = 0; a < 3; ++a) {
    if (!reader.Value(&g->origin_m[a])) return false;
  }
  if (!reader.Value(&g->resolution_m)) return false;
  for (int a = 0; a < 3; ++a) {
    std::int32_t n = 0;
    if (!reader.Value(&n)) return false;
    g->size[a] = n;
  }
  return g->origin_m.allFinite() && std::isfinite(g->resolution_m) && g->resolution_m > 0 &&
         (g->size.array() >= 1).all();
}

namespace {

// The model of `config`, `summary` and its parts, each made by FromParts or FromChunks
// (kMapLoadFailed: "<noun> <name> ...").
Expected<std::shared_ptr<const TerrainModel>> ModelOf(
    const AssessmentConfig& config, const AssessmentSummary& summary, Expected<SurfaceMap> surfaces,
    Expected<TerrainFields> fields, const std::string& noun, const std::string& name) {
  const auto fail = [&](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, noun + " " + name + " " + what};
  };
  if (Status s = config.Validate(); !s) {
    return fail("holds invalid assessment parameters: " + s.error().message);
  }
  if (!surfaces) return fail("is inconsistent: " + surfaces.error().message);
  if (!fields) return fail("is inconsistent: " + fields.error().message);
  Expected<std::shared_ptr<const TerrainModel>> model = TerrainModel::FromParts(
      config, summary, std::move(surfaces).value(), std::move(fields).value());
  if (!model) return fail("is inconsistent: " + model.error().message);
  return model;
}

}  // namespace

Expected<std::shared_ptr<const TerrainModel>> BuildModel(Payload payload, const std::string& noun,
                                                         const std::string& name) {
  Expected<SurfaceMap> surfaces = SurfaceMap::FromParts(
      payload.surface_geometry, std::move(payload.column_begin), std::move(payload.surfaces));
  Expected<TerrainFields> fields = TerrainFields::FromParts(payload.fields);
  return ModelOf(payload.config, payload.summary, std::move(surfaces), std::move(fields), noun,
                 name);
}

Expected<std::shared_ptr<const TerrainModel>> BuildModelFromChunks(
    const Payload& payload, std::vector<SurfaceMap::Chunk> surface_chunks,
    std::vector<TerrainFields::Chunk> field_chunks, const TerrainModel* checked,
    const std::string& noun, const std::string& name) {
  Expected<SurfaceMap> surfaces =
      SurfaceMap::FromChunks(payload.surface_geometry, std::move(surface_chunks),
                             checked != nullptr ? &checked->surfaces() : nullptr);
  Expected<TerrainFields> fields = TerrainFields::FromChunks(
      payload.fields, std::move(field_chunks), checked != nullptr ? &checked->fields() : nullptr);
  return ModelOf(payload.config, payload.summary, std::move(surfaces), std::move(fields), noun,
                 name);
}

}  // namespace strata::model_parts
