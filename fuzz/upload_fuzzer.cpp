// libFuzzer target: the UploadMap stream assembler (server/rpc/upload_assembler.hpp). The input
// is a stream of messages, each a 2-byte little-endian length and that many bytes of a
// serialised strata.v1.UploadMapRequest (an unparsable one is skipped, as gRPC would refuse
// it); the assembler, counting in a small memory budget, must refuse or take each message and
// never let the budget's count drift.
#include <cstddef>
#include <cstdint>

#include "maps/memory_budget.hpp"
#include "rpc/upload_assembler.hpp"
#include "strata/v1/map_service.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  strata::server::MemoryBudget budget(std::uint64_t{64} << 20);
  {
    strata::server::UploadAssembler upload(1'000'000, &budget);
    bool failed = false;
    for (std::size_t at = 0; at + 2 <= size && !failed;) {
      const std::size_t length = data[at] | (std::size_t{data[at + 1]} << 8);
      at += 2;
      const std::size_t take = length < size - at ? length : size - at;
      strata::v1::UploadMapRequest message;
      if (message.ParseFromArray(data + at, static_cast<int>(take))) {
        failed = !upload.Add(message).ok();
      }
      at += take;
    }
    if (!failed && upload.Finish().ok()) {
      const strata::server::UploadMapSource source = upload.TakeSource();
      if (source.points.size() * 12 != source.received_bytes) __builtin_trap();
    }
  }
  // Every reservation went back with the assembler and its source.
  if (budget.reserved(strata::server::MemoryBudget::Use::kUploads) != 0) __builtin_trap();
  return 0;
}
