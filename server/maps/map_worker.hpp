#pragma once
/// Making each new map in a process of its own (strata-map-worker), so that untrusted input
/// cannot take the server down: a reader that crashes or aborts on a malformed file (Debian's
/// PCL asserts), a cloud whose assessment needs more memory or CPU time than allowed, or a bug
/// of ours, fails that one map with a clear reason while the server keeps serving. The worker
/// limits itself (rlimits) before it reads anything, reports its progress on a pipe, and hands
/// back the saved model (and the cloud, for a map store) in a job directory of its own; the
/// server kills it at once when the map is deleted, the server shuts down, or the creation's
/// time runs out. No gRPC here.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "maps/map_build.hpp"

namespace strata::server {

/// Where the worker program is and what one job may use.
struct MapWorkerOptions {
  /// The strata-map-worker executable.
  std::filesystem::path program;
  /// Directory under which each job gets a directory of its own (removed after the job):
  /// uploaded points, the saved model and the cloud pass through it.
  std::filesystem::path scratch_dir = std::filesystem::temp_directory_path();
  /// Memory one job may allocate [bytes], > 0.
  std::uint64_t memory_bytes = std::uint64_t{4} << 30;
  /// CPU time one job may use, all its threads together [s], > 0.
  double cpu_s = 3600;
};

/// A MapBuilder that makes each map in a new worker process. The build fails with:
/// - the worker's own error, as BuildMapHere reports it (a malformed file: kMapLoadFailed);
/// - kResourceExhausted when the worker reached options.memory_bytes or options.cpu_s, or was
///   killed by SIGKILL that this server did not send (the kernel's out-of-memory killer, or
///   an operator: the message says what is known);
/// - kMapLoadFailed when it crashed (a signal), naming the signal and whether it was reading
///   the source or assessing it;
/// - kCancelled when monitor.should_stop asked to stop (the worker is killed at once);
/// - kResourceExhausted or kMapLoadFailed naming the path when a job directory or file cannot
///   be written or read back.
/// The worker's standard error (at most its last 4 KiB) goes to the server's log.
MapBuilder MapWorkerBuilder(MapWorkerOptions options);

/// A worker's environment: `parent`'s (null-terminated, as environ), with glibc's allocator
/// told to back its large blocks with transparent huge pages (GLIBC_TUNABLES=
/// glibc.malloc.hugetlb=1) unless `parent` tunes glibc itself. A worker is a fresh process
/// that faults in every page of the map it reads or makes, as a replica loading a map from the
/// store does, which this made 30% faster on a 400 m site (docs/benchmarks.md, "Map store").
std::vector<std::string> WorkerEnvironment(char** parent);

/// The strata-map-worker installed beside the running program (/proc/self/exe), or an empty
/// path when there is none.
std::filesystem::path MapWorkerBesideThisProgram();

}  // namespace strata::server
