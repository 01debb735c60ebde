#include "common/free_memory.hpp"

#include <malloc.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>

#include "common/log.hpp"
#include "strata/common/seconds_since.hpp"

namespace strata::server {

std::size_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

void RunWithHugePagesForLargeBlocks(char** argv) {
  constexpr std::string_view kTunable = "glibc.malloc.hugetlb";
  const char* set = std::getenv("GLIBC_TUNABLES");
  const std::string tunables = set != nullptr ? set : "";
  if (tunables.find(kTunable) != std::string::npos) return;
  const std::string with = (tunables.empty() ? "" : tunables + ":") + std::string(kTunable) + "=1";
  if (setenv("GLIBC_TUNABLES", with.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Still here: runs on without them (and a child it starts inherits the tunable).
  std::fprintf(stderr, "could not run again with %s=1 (%s): large blocks get small pages\n",
               kTunable.data(), std::strerror(errno));
}

void KeepFreedMemoryForReuse() {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
}

FreeMemoryReturner::FreeMemoryReturner(std::chrono::milliseconds quiet)
    : quiet_(quiet), thread_([this] { Run(); }) {}

FreeMemoryReturner::~FreeMemoryReturner() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

FreeMemoryReturner::Room::~Room() { returner_.Forget(this); }

void FreeMemoryReturner::Room::Request(std::size_t next_bytes) {
  returner_.Request(this, next_bytes);
}

void FreeMemoryReturner::Request(const Room* room, std::size_t next_bytes) {
  const std::size_t resident = ResidentBytes();
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mutex_);
    if (room != nullptr && next_bytes > 0) rooms_[room] = next_bytes;
    const std::size_t rooms = RoomBytesLocked();
    // Resident, not the allocator's free bytes: those count the pages already given back.
    const bool over = rooms > 0 && resident > resident_after_return_ + rooms;
    // A return due now stays due now: a later request only postpones a quiet one.
    if (over) {
      due_ = now;
    } else if (!due_ || *due_ > now) {
      due_ = now + quiet_;
    }
  }
  changed_.notify_all();
}

void FreeMemoryReturner::Forget(const Room* room) {
  std::lock_guard lock(mutex_);
  rooms_.erase(room);
}

std::size_t FreeMemoryReturner::RoomBytes() const {
  std::lock_guard lock(mutex_);
  return RoomBytesLocked();
}

std::size_t FreeMemoryReturner::RoomBytesLocked() const {
  std::size_t rooms = 0;
  for (const auto& [room, bytes] : rooms_) rooms += bytes;
  return rooms;
}

bool FreeMemoryReturner::WaitIdle(std::chrono::milliseconds limit) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, limit, [this] { return !due_ && !returning_; });
}

void FreeMemoryReturner::Run() {
  std::unique_lock lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return stopping_ || due_; });
    if (stopping_) return;
    if (std::chrono::steady_clock::now() < *due_) {
      const auto due = *due_;  // A request meanwhile moves it: looked at again on waking.
      changed_.wait_until(lock, due);
      continue;
    }
    due_.reset();
    returning_ = true;
    lock.unlock();
    const auto start = std::chrono::steady_clock::now();
    const std::size_t resident_before = ResidentBytes();
    const bool returned = malloc_trim(0) != 0;
    const std::size_t resident = ResidentBytes();
    LogRecord(LogLevel::kDebug, "free_memory_returned")
        .Add("any", returned ? "yes" : "no")
        .Add("s", common::SecondsSince(start))
        .Add("resident_before_mb", static_cast<double>(resident_before) / 1e6)
        .Add("resident_after_mb", static_cast<double>(resident) / 1e6);
    lock.lock();
    resident_after_return_ = resident;
    returning_ = false;
    changed_.notify_all();
  }
}

}  // namespace strata::server
