// libFuzzer target: strata::JoinModel, which a map store's tiled terrains are loaded with. The
// input is a tiled model's parts, each a u32 little-endian length and its bytes: the header
// without its last eight bytes (the target appends the right checksum, as saved_model's does,
// so that mutations reach the header's parser), then the tiles, whose integrity the store
// checks by their names and the joiner by their shape. Any bytes give a model or an error, and
// a model it gives survives a round trip: cut again and joined, it saves to the same bytes.
#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view input(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  while (input.size() >= 4) {
    std::uint32_t length = 0;
    std::memcpy(&length, input.data(), 4);
    input.remove_prefix(4);
    if (length > input.size()) length = static_cast<std::uint32_t>(input.size());
    parts.emplace_back(input.substr(0, length));
    input.remove_prefix(length);
  }
  if (parts.empty()) return 0;
  const std::uint64_t checksum = XXH3_64bits(parts[0].data(), parts[0].size());
  parts[0].append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  const std::vector<std::string_view> tiles(parts.begin() + 1, parts.end());
  const auto model = strata::JoinModel(parts[0], tiles, "fuzz");
  if (!model.ok()) return 0;
  const strata::TiledModel cut = strata::CutModel(**model);
  const std::vector<std::string_view> cut_tiles(cut.tiles.begin(), cut.tiles.end());
  const auto again = strata::JoinModel(cut.header, cut_tiles, "fuzz-again");
  if (!again.ok() || strata::SerializeModel(**again) != strata::SerializeModel(**model)) {
    __builtin_trap();
  }
  return 0;
}
