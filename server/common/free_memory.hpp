#pragma once
/// How a server's freed memory is kept for its next map version, and given back once quiet.
///
/// A version of a site's map is made of whole arrays (a 400 m site's model and graph: about
/// 500 MB) built beside the previous version's, which is freed once the new one is published.
/// glibc gives each block that large a mapping of its own and unmaps it when freed, so every
/// version faulted all its pages in anew. On a VM whose host takes back what its guest freed,
/// those faults were most of a scan's time: 1.0 s of a 2.1 s scan on the 400 m site, against
/// 0.06 s for the same join into pages kept (docs/benchmarks.md, "Edits through UpdateMap").
/// KeepFreedMemoryForReuse has glibc keep them; a FreeMemoryReturner gives what is free back
/// to the system once versions and loads stop coming, so that a server whose maps stopped
/// changing holds what its maps hold.
///
/// That holds for the main thread's arena only. glibc serves every other thread (a server's
/// calls, its assessment jobs) from arenas of at most 64 MB, and maps a larger block anew
/// whatever mallopt says: a scan made on a call's thread faulted its model in again (1.1-1.3 s
/// against 0.3 s). One arena for all would keep them, at 8-18% of planning throughput. Huge
/// pages (RunWithHugePagesForLargeBlocks) make such a mapping's faults 512 times fewer: 300 MB
/// mapped anew and written in 0.03 s instead of 0.9-1.1 s.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

namespace strata::server {

/// This process's resident memory [bytes] (/proc/self/statm).
std::size_t ResidentBytes();

/// Runs this program with glibc's malloc asking for transparent huge pages for what it maps
/// (the tunable glibc.malloc.hugetlb=1, read only when a process starts): unless
/// GLIBC_TUNABLES names glibc.malloc.hugetlb already (a choice made outside stands), the
/// program is executed again (/proc/self/exe, the same arguments and process) with it added.
/// Returns when it runs so already, or when it cannot be executed again (said on stderr).
/// Call first thing in main, before any thread starts.
void RunWithHugePagesForLargeBlocks(char** argv);

/// Has glibc's malloc serve every block from its heaps (none gets a mapping of its own) and
/// never shrink them by itself (mallopt M_MMAP_MAX 0, M_TRIM_THRESHOLD at its largest):
/// what is freed stays for the next allocations until a FreeMemoryReturner gives it back.
/// Call once, at a server's start, before its threads start.
void KeepFreedMemoryForReuse();

class FreeMemoryReturner {
 public:
  /// Longer than the gaps between a site's versions while robots' scans come in (up to about
  /// 10 s on a 400 m site beside 8 planners): their memory is reused, not given back and
  /// faulted in again.
  static constexpr std::chrono::milliseconds kDefaultQuiet{30'000};

  /// Memory is given back `quiet` after the last request.
  explicit FreeMemoryReturner(std::chrono::milliseconds quiet = kDefaultQuiet);
  ~FreeMemoryReturner();
  FreeMemoryReturner(const FreeMemoryReturner&) = delete;
  FreeMemoryReturner& operator=(const FreeMemoryReturner&) = delete;

  /// What one holder of map versions (a registry) will want for its next ones. The rooms of a
  /// returner's holders add up: a process whose registries each hold a site (replicas side by
  /// side in a benchmark) keeps room for each. The holder outlives its room.
  class Room {
   public:
    explicit Room(FreeMemoryReturner& returner) : returner_(returner) {}
    ~Room();
    Room(const Room&) = delete;
    Room& operator=(const Room&) = delete;

    /// Much memory was freed (a version let go, a map made or loaded); `next_bytes` is what
    /// this holder's next allocations of the kind will want (a map's version: its model and
    /// graphs), 0: what it last said. See FreeMemoryReturner::Request.
    void Request(std::size_t next_bytes = 0);

   private:
    FreeMemoryReturner& returner_;
  };

  /// Much memory was freed: the allocator's free memory goes back to the system (malloc_trim)
  /// on the returner's thread once no request has come for the quiet period. When the process
  /// holds more than its holders' rooms together beyond what it held after the last
  /// return, the free memory goes back at once, so that memory stays bounded while versions
  /// keep coming (the heap's holes do not all fit the next arrays). The caller does not wait.
  void Request() { Request(nullptr, 0); }

  /// The bytes kept free for the holders' next versions: their rooms together.
  std::size_t RoomBytes() const;

  /// Whether no return is pending or running within `limit` (for tests).
  bool WaitIdle(std::chrono::milliseconds limit);

 private:
  void Request(const Room* room, std::size_t next_bytes);
  void Forget(const Room* room);
  std::size_t RoomBytesLocked() const;
  void Run();

  const std::chrono::milliseconds quiet_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<std::chrono::steady_clock::time_point> due_;  // A return pending, from then.
  std::size_t resident_after_return_ = 0;                     // The process's resident bytes then.
  std::map<const Room*, std::size_t> rooms_;                  // Each holder's last non-zero word.
  bool returning_ = false;
  bool stopping_ = false;
  std::thread thread_;  // Last: started once the rest is.
};

}  // namespace strata::server
