#pragma once
// Copies into fresh memory with its pages faulted in on the other core.
//
// A version of a site's model or graph is the base's arrays copied, with a few columns renewed
// (a join, a graph patch). Each page of a new array is cleared by the kernel as the copy first
// writes it, and on a large map that clearing is as much work as the copy: on the 1 km site
// 46% of a join's samples were the kernel clearing pages. Here a second OpenMP thread faults
// the pages in (MADV_POPULATE_WRITE: the page tables only, no byte written) a little ahead of
// the copy, so the clearing runs beside it. Without OpenMP, or where the kernel lacks
// MADV_POPULATE_WRITE (before Linux 5.14), the copy runs alone, as before.
#include <atomic>
#include <cstddef>
#include <exception>
#include <optional>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace strata::internal {

/// Memory a fill writes, front to back.
struct PageRegion {
  const void* data = nullptr;
  std::size_t bytes = 0;
};

/// The whole allocation of `v` (its capacity), which a fill appending to it writes.
template <typename T>
PageRegion CapacityOf(const std::vector<T>& v) {
  return {v.data(), v.capacity() * sizeof(T)};
}

/// Below this many bytes in all, a fill runs alone: a thread's start costs more than the
/// pages' faults save (a spiral's join is 12 MB).
inline constexpr std::size_t kLeastBytesToFaultAhead = std::size_t{64} << 20;

/// Faults in the pages of `regions`, all at the same pace (a fill appends to them together,
/// column by column), until `done` is set or every page is in. False when the kernel cannot.
bool FaultInPages(std::span<const PageRegion> regions, const std::atomic<bool>& done);

/// Returns fill() (run on the calling thread), while a second thread faults in the pages of
/// `regions` ahead of it when they are large enough. An exception fill() throws is rethrown.
template <typename Fill>
std::invoke_result_t<Fill&> FillWithPagesFaultedAhead(std::span<const PageRegion> regions,
                                                      Fill&& fill) {
#ifdef _OPENMP
  std::size_t bytes = 0;
  for (const PageRegion& r : regions) bytes += r.bytes;
  if (bytes >= kLeastBytesToFaultAhead && omp_get_level() == 0) {
    std::optional<std::invoke_result_t<Fill&>> result;
    std::exception_ptr thrown;
    std::atomic<bool> done{false};
#pragma omp parallel num_threads(2)
    {
      if (omp_get_thread_num() == 0) {
        try {
          result.emplace(fill());
        } catch (...) {
          thrown = std::current_exception();
        }
        done.store(true, std::memory_order_relaxed);
      } else {
        FaultInPages(regions, done);
      }
    }
    if (thrown) std::rethrow_exception(thrown);
    return std::move(*result);
  }
#endif
  (void)regions;
  return fill();
}

}  // namespace strata::internal
