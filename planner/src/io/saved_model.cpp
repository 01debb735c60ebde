#include "strata/io/saved_model.hpp"

#include <filesystem>
#include <fstream>
#include <utility>
#include <vector>

#include "binary_file.hpp"
#include "model_parts.hpp"

namespace strata {
namespace {

using binary_file::Decode;
using binary_file::Encode;
using binary_file::Reader;
using binary_file::ReadFields;
using binary_file::Sink;
using binary_file::WriteFields;
using model_parts::BuildModel;
using model_parts::DecodeSurface;
using model_parts::EncodeSurface;
using model_parts::kIntervalRecordBytes;
using model_parts::kSurfaceRecordBytes;
using model_parts::Payload;
using model_parts::ReadGeometry;
using model_parts::WriteGeometry;

const binary_file::FileKind kSavedModelKind{kSavedModelMagic, kSavedModelFormatVersion,
                                            "saved model",
                                            "assess the map again and save it with this build"};

// The column offsets of `chunks` as one array over the whole grid, as Sink::Array writes it:
// each chunk's offsets moved by `held(chunk)` of every chunk before it.
template <typename Chunk, typename Held>
void WriteJoinedOffsets(Sink& sink, const std::vector<Chunk>& chunks, const Held& held) {
  std::uint64_t count = 1;
  for (const Chunk& chunk : chunks) count += chunk->column_begin.size() - 1;
  sink.Value(count);
  sink.Value(std::uint32_t{0});
  std::uint32_t base = 0;
  std::vector<std::uint32_t> moved;
  for (const Chunk& chunk : chunks) {
    moved.assign(chunk->column_begin.begin() + 1, chunk->column_begin.end());
    for (std::uint32_t& offset : moved) offset += base;
    sink.Bytes(moved.data(), moved.size() * sizeof(std::uint32_t));
    base += static_cast<std::uint32_t>(held(*chunk));
  }
}

// The fields' values of every chunk, one after another, as Sink::Array writes one array.
template <typename Values>
void WriteJoinedValues(Sink& sink, const TerrainFields& fields, const Values& values) {
  sink.Value(static_cast<std::uint64_t>(fields.cell_count()));
  for (const TerrainFields::Chunk& chunk : fields.chunks()) {
    const auto& v = values(*chunk);
    sink.Bytes(v.data(), v.size() * sizeof(v[0]));
  }
}

// The model's arrays are written as whole-grid arrays, chunk after chunk (the format predates
// the chunks and does not depend on them).
void WritePayload(Sink& sink, const TerrainModel& model) {
  WriteFields(sink, model.config());
  WriteFields(sink, model.summary());
  const SurfaceMap& surfaces = model.surfaces();
  WriteGeometry(sink, surfaces.geometry());
  WriteJoinedOffsets(sink, surfaces.chunks(),
                     [](const ColumnSurfaces& chunk) { return chunk.surfaces.size(); });
  // Records field by field (the structs' padding would make the bytes depend on the
  // compiler), gathered into chunks so that the checksum sees large writes.
  sink.Value(static_cast<std::uint64_t>(surfaces.surface_count()));
  for (const SurfaceMap::Chunk& chunk : surfaces.chunks()) {
    sink.Records<kSurfaceRecordBytes>(chunk->surfaces, EncodeSurface);
  }
  const TerrainFields& fields = model.fields();
  const TerrainFields::Scalars& f = fields.scalars();
  WriteGeometry(sink, f.geometry);
  sink.Value(f.distance_cap_m);
  sink.Value(f.safety_step);
  sink.Value(f.safety_background);
  WriteJoinedOffsets(sink, fields.chunks(), [](const TerrainFields::Runs& chunk) {
    return chunk.intervals.size() - 1;  // The sentinel aside.
  });
  std::uint64_t runs = 1;  // The final sentinel.
  for (const TerrainFields::Chunk& chunk : fields.chunks()) runs += chunk->intervals.size() - 1;
  sink.Value(runs);
  const auto encode = [](const TerrainFields::Interval& i, char* b) {
    Encode(b, i.first_layer);
    Encode(b + 4, i.offset);
  };
  std::uint32_t value_base = 0;
  std::vector<TerrainFields::Interval> moved;
  for (const TerrainFields::Chunk& chunk : fields.chunks()) {
    moved.assign(chunk->intervals.begin(), chunk->intervals.end() - 1);
    for (TerrainFields::Interval& interval : moved) interval.offset += value_base;
    sink.Records<kIntervalRecordBytes>(moved, encode);
    value_base += static_cast<std::uint32_t>(chunk->distance.size());
  }
  sink.Records<kIntervalRecordBytes>(std::vector<TerrainFields::Interval>{{0, value_base}}, encode);
  WriteJoinedValues(
      sink, fields, [](const TerrainFields::Runs& chunk) -> const auto& { return chunk.distance; });
  WriteJoinedValues(
      sink, fields, [](const TerrainFields::Runs& chunk) -> const auto& { return chunk.safety; });
}

bool ReadPayload(Reader& reader, Payload* p, std::string* problem) {
  if (!ReadFields(reader, &p->config, problem) || !ReadFields(reader, &p->summary, problem)) {
    return false;
  }
  if (!ReadGeometry(reader, &p->surface_geometry) || !reader.Array(&p->column_begin)) return false;
  std::uint64_t n = 0;
  if (!reader.Count(&n, kSurfaceRecordBytes)) return false;
  p->surfaces.resize(n);
  if (!reader.Records<kSurfaceRecordBytes>(
          n, [&](const char* b, std::uint64_t i) { return DecodeSurface(b, &p->surfaces[i]); })) {
    return false;
  }
  TerrainFields::Parts& f = p->fields;
  if (!ReadGeometry(reader, &f.geometry) || !reader.Value(&f.distance_cap_m) ||
      !reader.Value(&f.safety_step) || !reader.Value(&f.safety_background) ||
      !reader.Array(&f.column_begin) || !reader.Count(&n, kIntervalRecordBytes)) {
    return false;
  }
  f.intervals.resize(n);
  if (!reader.Records<kIntervalRecordBytes>(n, [&](const char* b, std::uint64_t i) {
        f.intervals[i] = {Decode<std::int32_t>(b), Decode<std::uint32_t>(b + 4)};
        return true;
      })) {
    return false;
  }
  return reader.Array(&f.distance) && reader.Array(&f.safety);
}

// Reads the payload of a saved model into *payload.
auto PayloadInto(Payload* payload) {
  return [payload](Reader& reader, std::string* problem) {
    return ReadPayload(reader, payload, problem);
  };
}

}  // namespace

bool IsSavedModel(std::string_view first_bytes) {
  return first_bytes.substr(0, kSavedModelMagic.size()) == kSavedModelMagic;
}

bool IsSavedModelFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char magic[kSavedModelMagic.size()];
  file.read(magic, sizeof(magic));
  return file.gcount() == sizeof(magic) && IsSavedModel(std::string_view(magic, sizeof(magic)));
}

Expected<AssessmentConfig> ReadSavedModelConfig(const NamedFile& named) {
  const std::string& path = named.path;
  const std::string& name = named.name;
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  std::ifstream file(path, std::ios::binary);
  if (error || !file) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " cannot be read"};
  }
  binary_file::FileSource source(&file);
  std::string writer;
  if (Status s = binary_file::ReadHeader(source, size, kSavedModelKind, name, &writer); !s) {
    return s.error();
  }
  Reader reader(&source);
  AssessmentConfig config;
  std::string problem;
  if (!ReadFields(reader, &config, &problem)) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " written by " + writer +
                                                " has unreadable parameters" +
                                                (problem.empty() ? "" : ": " + problem)};
  }
  return config;
}

namespace {

// Writes the payload of `model`.
auto PayloadOf(const TerrainModel& model) {
  return [&model](Sink& sink) { WritePayload(sink, model); };
}

}  // namespace

std::string SerializeModel(const TerrainModel& model) {
  std::string out;
  Sink sink(&out);
  binary_file::WriteFrame(sink, kSavedModelKind, PayloadOf(model));
  return out;
}

Status SaveModel(const TerrainModel& model, const std::string& path) {
  return binary_file::WriteFileAtomically(path, kSavedModelKind, PayloadOf(model));
}

Expected<std::shared_ptr<const TerrainModel>> DeserializeModel(std::string_view bytes,
                                                               const std::string& name) {
  binary_file::MemorySource source(bytes);
  Payload payload;
  if (Status s = binary_file::ReadFrame(source, bytes.size(), kSavedModelKind, name,
                                        PayloadInto(&payload));
      !s) {
    return s.error();
  }
  return BuildModel(std::move(payload), "saved model", name);
}

Expected<std::shared_ptr<const TerrainModel>> LoadModel(const NamedFile& named) {
  Payload payload;
  if (Status s = binary_file::ReadFrameFromFile(named, kSavedModelKind, PayloadInto(&payload));
      !s) {
    return s.error();
  }
  return BuildModel(std::move(payload), "saved model", named.name);
}

}  // namespace strata
