#include "maps/graph_writer.hpp"

#include <utility>

namespace strata::server {
namespace {

// Writing a graph needs little stack: its records go out in chunks of a few hundred KB.
constexpr std::size_t kStackBytes = 2 << 20;
// The least CPU priority there is: a graph kept late costs a cold replica a build at most.
constexpr int kNiceness = 19;

}  // namespace

GraphWriter::GraphWriter() : thread_(1, kStackBytes, kMaxGraphWritesWaiting, kNiceness) {}

bool GraphWriter::Keep(const std::string& key, std::function<void()> write, bool* replaced) {
  std::function<void()> dropped;  // Let go after the lock: it may hold a version's graph.
  std::lock_guard lock(mutex_);
  const auto waiting = newest_.find(key);
  if (replaced != nullptr) *replaced = waiting != newest_.end();
  if (waiting != newest_.end()) {
    // The job queued for the key writes whatever is newest when it runs.
    dropped = std::exchange(waiting->second, std::move(write));
    return true;
  }
  // Queued under the lock, so that no other Keep of the key counts on a job not queued. The
  // job takes the lock only once the thread has let go of the queue's.
  if (!thread_.Post([this, key] { WriteNewest(key); })) return false;
  newest_.emplace(key, std::move(write));
  return true;
}

void GraphWriter::WriteNewest(const std::string& key) {
  std::function<void()> write;
  {
    std::lock_guard lock(mutex_);
    const auto waiting = newest_.find(key);
    if (waiting == newest_.end()) return;
    write = std::move(waiting->second);
    newest_.erase(waiting);
  }
  write();
}

}  // namespace strata::server
