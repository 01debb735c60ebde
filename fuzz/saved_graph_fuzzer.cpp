// libFuzzer target: strata::DeserializeGraph, the saved-graph reader a server loads the
// graphs of its map store with, onto the floor-and-wall model its seed was built on. As in
// saved_model_fuzzer.cpp, the input is the file without its last eight bytes and the target
// appends the right checksum, so that mutations reach the parser. Any bytes give a graph or
// an error, and a graph it gives survives a round trip: saved again and read back, it saves to
// the same bytes, and every node's neighbours are nodes.
#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "floor_and_wall.hpp"
#include "strata/io/saved_graph.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto model = strata::fuzz::FloorAndWallModel();
  std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::uint64_t checksum = XXH3_64bits(data, size);
  bytes.append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  const auto graph = strata::DeserializeGraph(bytes, *model, "fuzz.sgr");
  if (!graph.ok()) return 0;
  for (int n = 0; n < graph->node_count(); ++n) {
    graph->ForEachNeighbor(n, [&](int m) {
      if (m < 0 || m >= graph->node_count()) __builtin_trap();
    });
  }
  const std::string saved = strata::SerializeGraph(*graph);
  const auto again = strata::DeserializeGraph(saved, *model, "fuzz-again.sgr");
  if (!again.ok() || strata::SerializeGraph(*again) != saved) __builtin_trap();
  return 0;
}
