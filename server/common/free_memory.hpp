#pragma once
/// Gives the memory that glibc's allocator keeps free back to the system, on a thread of its
/// own. glibc keeps what a program frees in its arenas for later allocations and by itself
/// returns only the top of the main heap. A server whose robots' scans make a new version of a
/// site's map every second or so (maps/map_editor.hpp) frees the previous version's model and
/// graphs (hundreds of MB) as often, scattered through the arenas, and its resident memory
/// would grow with what glibc keeps rather than with what it holds (docs/benchmarks.md, "Scans
/// sustained").
#include "common/job_threads.hpp"

namespace strata::server {

class FreeMemoryReturner {
 public:
  FreeMemoryReturner();

  /// Returns the allocator's free memory soon, on the returner's thread (malloc_trim): the
  /// caller does not wait. A request made while one waits is the same request.
  void Request();

  /// Returns once every request made so far has been carried out (for tests).
  void WaitIdle() { thread_.WaitIdle(); }

 private:
  JobThreads thread_;
};

}  // namespace strata::server
