// libFuzzer target: strata::DeserializeModel, the saved-model reader strata-server loads map
// files and its map store with. The input is a saved model without its last eight bytes: the
// target appends the right checksum (XXH3-64 of everything before it), so that mutations reach
// the payload's parser instead of stopping at "its checksum does not match" (a wrong checksum
// is the one case this leaves to saved_model_test). Any bytes give a model or an error, and a
// model it gives survives a round trip: saved again and read back, it saves to the same bytes.
#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "strata/io/saved_model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::uint64_t checksum = XXH3_64bits(data, size);
  bytes.append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  const auto model = strata::DeserializeModel(bytes, "fuzz.smd");
  if (!model.ok()) return 0;
  const std::string saved = strata::SerializeModel(**model);
  const auto again = strata::DeserializeModel(saved, "fuzz-again.smd");
  if (!again.ok() || strata::SerializeModel(**again) != saved) __builtin_trap();
  return 0;
}
