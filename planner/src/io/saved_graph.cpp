#include "strata/io/saved_graph.hpp"

#include <utility>

#include <fmt/format.h>
#include <xxhash.h>

#include "binary_file.hpp"
#include "strata/io/saved_model.hpp"

namespace strata {
namespace {

using binary_file::Reader;
using binary_file::Sink;

const binary_file::FileKind kSavedGraphKind{kSavedGraphMagic, kSavedGraphFormatVersion,
                                            "saved graph", "the graph is built again instead"};

// Bytes per stored node: clearance, component, rim distance.
constexpr std::size_t kNodeRecordBytes = 4 + 4 + 4;

void WritePayload(Sink& sink, const SurfaceGraph& graph) {
  binary_file::WriteFields(sink, graph.params());
  sink.Value(static_cast<std::uint64_t>(graph.node_count()));
  sink.Value(static_cast<std::int64_t>(graph.component_count()));
  sink.Value(graph.open_ground_clearance_m());
  const std::span<const SurfaceGraph::Node> nodes = graph.nodes();
  const std::span<const std::int32_t> components = graph.components();
  const std::span<const float> rim = graph.edge_distances();
  // Records field by field, gathered into chunks so that the checksum sees large writes.
  constexpr std::size_t kChunk = 1 << 14;
  char buffer[kChunk * kNodeRecordBytes];
  for (std::size_t first = 0; first < nodes.size(); first += kChunk) {
    const std::size_t count = std::min(kChunk, nodes.size() - first);
    for (std::size_t i = 0; i < count; ++i) {
      char* b = buffer + i * kNodeRecordBytes;
      binary_file::Encode(b, nodes[first + i].clearance_m);
      binary_file::Encode(b + 4, components[first + i]);
      binary_file::Encode(b + 8, rim[first + i]);
    }
    sink.Bytes(buffer, count * kNodeRecordBytes);
  }
  sink.Value(static_cast<std::int64_t>(graph.landmark_count()));
  const std::span<const float> landmarks = graph.landmark_distances();
  sink.Value(static_cast<std::uint64_t>(landmarks.size()));
  sink.Bytes(landmarks.data(), landmarks.size_bytes());
}

bool ReadPayload(Reader& reader, SurfaceGraph::Parts* parts, std::string* problem) {
  if (!binary_file::ReadFields(reader, &parts->params, problem)) return false;
  std::uint64_t nodes = 0;
  std::int64_t components = 0;
  if (!reader.Count(&nodes, kNodeRecordBytes) || !reader.Value(&components) ||
      !reader.Value(&parts->open_ground_clearance_m)) {
    return false;
  }
  if (components < 0 || static_cast<std::uint64_t>(components) > nodes) {
    *problem = fmt::format("{} components for {} nodes", components, nodes);
    return false;
  }
  parts->component_count = static_cast<int>(components);
  parts->clearance_m.resize(nodes);
  parts->components.resize(nodes);
  parts->edge_distance_m.resize(nodes);
  if (!reader.Records<kNodeRecordBytes>(nodes, [&](const char* b, std::uint64_t i) {
        parts->clearance_m[i] = binary_file::Decode<float>(b);
        parts->components[i] = binary_file::Decode<std::int32_t>(b + 4);
        parts->edge_distance_m[i] = binary_file::Decode<float>(b + 8);
        return true;
      })) {
    return false;
  }
  std::int64_t landmarks = 0;
  if (!reader.Value(&landmarks)) return false;
  if (landmarks < 0 || landmarks > SurfaceGraph::kMaxLandmarks) {
    *problem = fmt::format("{} landmarks (at most {})", landmarks, SurfaceGraph::kMaxLandmarks);
    return false;
  }
  parts->landmark_count = static_cast<int>(landmarks);
  return reader.Array(&parts->landmark_distance);
}

auto PayloadInto(SurfaceGraph::Parts* parts) {
  return
      [parts](Reader& reader, std::string* problem) { return ReadPayload(reader, parts, problem); };
}

auto PayloadOf(const SurfaceGraph& graph) {
  return [&graph](Sink& sink) { WritePayload(sink, graph); };
}

// The graph of `parts` on `model`, its refusals naming the file.
Expected<SurfaceGraph> GraphOf(SurfaceGraph::Parts parts, const TerrainModel& model,
                               const std::string& name) {
  Expected<SurfaceGraph> graph = SurfaceGraph::FromParts(model, std::move(parts));
  if (graph || graph.error().code != ErrorCode::kMapLoadFailed) return graph;
  return Error{ErrorCode::kMapLoadFailed, "saved graph " + name + ": " + graph.error().message};
}

}  // namespace

std::string SerializeGraph(const SurfaceGraph& graph) {
  std::string out;
  Sink sink(&out);
  binary_file::WriteFrame(sink, kSavedGraphKind, PayloadOf(graph));
  return out;
}

Status SaveGraph(const SurfaceGraph& graph, const std::string& path) {
  return binary_file::WriteFileAtomically(path, kSavedGraphKind, PayloadOf(graph));
}

Expected<SurfaceGraph> DeserializeGraph(std::string_view bytes, const TerrainModel& model,
                                        const std::string& name) {
  binary_file::MemorySource source(bytes);
  SurfaceGraph::Parts parts;
  if (Status s =
          binary_file::ReadFrame(source, bytes.size(), kSavedGraphKind, name, PayloadInto(&parts));
      !s) {
    return s.error();
  }
  return GraphOf(std::move(parts), model, name);
}

Expected<SurfaceGraph> LoadGraph(const NamedFile& file, const TerrainModel& model) {
  SurfaceGraph::Parts parts;
  if (Status s = binary_file::ReadFrameFromFile(file, kSavedGraphKind, PayloadInto(&parts)); !s) {
    return s.error();
  }
  return GraphOf(std::move(parts), model, file.name);
}

std::string SavedGraphKey(const TraversabilityParams& params) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_128bits_reset(state);
  const auto add = [state](const void* data, std::size_t n) {
    XXH3_128bits_update(state, data, n);
  };
  for (const std::uint32_t version : {kSavedGraphFormatVersion, kSavedModelFormatVersion}) {
    add(&version, sizeof(version));
  }
  ForEachField(params, [&](const char* name, const double& value) {
    add(name, std::char_traits<char>::length(name) + 1);  // With its NUL: names stay apart.
    add(&value, sizeof(value));
  });
  const XXH128_hash_t hash = XXH3_128bits_digest(state);
  XXH3_freeState(state);
  return fmt::format("{:016x}{:016x}", hash.high64, hash.low64);
}

}  // namespace strata
