// Linked into strata-map-worker in the sanitised build only (STRATA_SANITIZE): the worker must
// end there as it ends in the product, or its tests test the sanitiser.
// - A signal (a reader's crash, a test's kill) kills it, and the server names the signal;
//   ASan would otherwise catch SIGSEGV, print a report and exit with its own code.
// - Memory past --max-assessment-memory (RLIMIT_DATA) ends it with the out-of-memory exit
//   code, as the new-handler does in the product. ASan's operator new cannot throw
//   std::bad_alloc: it reports "allocator is out of memory" and dies, so the report callback
//   below turns that one report into the same exit. Every other report ends the worker as ASan
//   would (exit code 1, the report in the server's log).
#include <sanitizer/asan_interface.h>

#include <cstdlib>
#include <cstring>

#include "maps/map_worker_protocol.hpp"

extern "C" {

// NOLINTNEXTLINE(bugprone-reserved-identifier): the name ASan looks for.
const char* __asan_default_options() { return "handle_segv=0:handle_sigbus=0"; }

// libomp keeps per-thread data of OpenMP threads started from a non-main thread until it is
// unloaded; LeakSanitizer counts it as leaked at exit. Nothing of Strata's is suppressed.
// NOLINTNEXTLINE(bugprone-reserved-identifier): the name LeakSanitizer looks for.
const char* __lsan_default_suppressions() { return "leak:libomp.so\n"; }

}  // extern "C"

namespace {

void OnSanitizerReport(const char* report) {
  if (std::strstr(report, "allocator is out of memory") != nullptr) {
    std::_Exit(strata::server::kWorkerExitOutOfMemory);
  }
}

[[maybe_unused]] const bool kReportCallbackSet =
    (__asan_set_error_report_callback(OnSanitizerReport), true);

}  // namespace
