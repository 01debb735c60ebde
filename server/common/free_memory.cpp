#include "common/free_memory.hpp"

#include <malloc.h>

#include <chrono>

#include "common/log.hpp"
#include "strata/common/seconds_since.hpp"

namespace strata::server {
namespace {

constexpr std::size_t kStackBytes = 64 * 1024;  // malloc_trim needs little.

}  // namespace

// One job may wait: it runs after every free made before it, so a second would add nothing.
FreeMemoryReturner::FreeMemoryReturner() : thread_(1, kStackBytes, 1) {}

void FreeMemoryReturner::Request() {
  thread_.Post([] {
    const auto start = std::chrono::steady_clock::now();
    const bool returned = malloc_trim(0) != 0;
    LogRecord(LogLevel::kDebug, "free_memory_returned")
        .Add("any", returned ? "yes" : "no")
        .Add("s", common::SecondsSince(start));
  });
}

}  // namespace strata::server
