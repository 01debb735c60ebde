#pragma once
/// Writes robots' surface graphs to the map store on a thread of its own, at the least CPU
/// priority, and only the newest of each map and robot.
///
/// A graph is kept so that a replica that starts cold loads it instead of building it; no plan
/// waits for the write. Replicas that hold a version patch its graphs into the next version's
/// themselves, so of a map's graphs for one robot only the newest matters. While robots' scans
/// come in, a kilometre site gets a version every second or two, and writing each one's graph
/// whole (300 MB, 0.6-1.3 s of a core) took CPU from the plans beside it and, where the writes
/// fell behind, held the versions queued for them in memory. So a graph waiting to be written
/// gives way to a newer one of the same map and robot (its memory goes at once), and the
/// writer runs at nice 19: it writes when the plans leave a core free.
/// No gRPC here.
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <unordered_map>

#include "common/job_threads.hpp"

namespace strata::server {

/// Graph writes waiting at most, each for another map or robot; more are not made (a replica
/// that needs one builds it).
inline constexpr std::size_t kMaxGraphWritesWaiting = 4;

class GraphWriter {
 public:
  GraphWriter();
  GraphWriter(const GraphWriter&) = delete;
  GraphWriter& operator=(const GraphWriter&) = delete;

  /// Queues `write` as the graph of `key` (a map and a robot's traversability). A write of
  /// `key` still waiting is dropped for it (`replaced` true, when given). False when writes of
  /// kMaxGraphWritesWaiting other keys wait: `write` is not made. `write` must not throw.
  bool Keep(const std::string& key, std::function<void()> write, bool* replaced = nullptr);

  /// Returns once every write queued so far has been made or dropped.
  void WaitIdle() { thread_.WaitIdle(); }

 private:
  void WriteNewest(const std::string& key);

  std::mutex mutex_;
  std::unordered_map<std::string, std::function<void()>> newest_;  // Waiting, by key.
  JobThreads thread_;  // Last: stopped (its jobs run) before the rest goes.
};

}  // namespace strata::server
