#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>

#include "prefault_internal.hpp"

namespace strata::internal {

bool FaultInPages(std::span<const PageRegion> regions, const std::atomic<bool>& done) {
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  // Steps of 8 MB of the largest region, the others in proportion: a few milliseconds each, so
  // the faults stay near the copy and stop soon after it ends.
  constexpr std::size_t kStepBytes = std::size_t{8} << 20;
  std::size_t largest = 0;
  for (const PageRegion& r : regions) largest = std::max(largest, r.bytes);
  const std::size_t steps = (largest + kStepBytes - 1) / kStepBytes;
  for (std::size_t step = 0; step < steps; ++step) {
    for (const PageRegion& r : regions) {
      if (done.load(std::memory_order_relaxed)) return true;
      // The whole pages inside the region (the copy faults the partial ones at its ends).
      const auto start = reinterpret_cast<std::uintptr_t>(r.data);
      const std::uintptr_t first = (start + page - 1) / page * page;
      const std::uintptr_t end = (start + r.bytes) / page * page;
      if (end <= first) continue;
      const std::uintptr_t length = end - first;
      const std::uintptr_t from = first + length / steps * step / page * page;
      const std::uintptr_t to =
          step + 1 == steps ? end : first + length / steps * (step + 1) / page * page;
      if (to <= from) continue;
      // NOLINTNEXTLINE(performance-no-int-to-ptr): the pages of a live allocation.
      if (madvise(reinterpret_cast<void*>(from), to - from, MADV_POPULATE_WRITE) != 0 &&
          errno == EINVAL) {
        return false;  // A kernel without it: the copy faults its pages itself.
      }
    }
  }
  return true;
}

}  // namespace strata::internal
