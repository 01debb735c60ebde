#pragma once
// Thread counts of the OpenMP-parallel stages. The stages are plain `#pragma omp` loops, so
// the library also builds without OpenMP (the ThreadSanitizer build does: libgomp is not
// instrumented) and then runs them on the calling thread.
#include <algorithm>
#include <thread>

namespace strata::internal {

/// `requested` threads, or one per core when it is <= 0.
inline int ResolveThreadCount(int requested) {
  if (requested > 0) return requested;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace strata::internal
