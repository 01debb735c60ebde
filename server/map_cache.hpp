#pragma once
/// The map versions a server holds in memory when its maps live in a map store
/// (map_store.hpp): loaded on demand, once, and dropped least recently used first when their
/// bytes pass a budget. Dropping only forgets the map here; the store keeps it, and a plan
/// holding it finishes on it (it is freed when that plan lets go). No gRPC here.
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "service_error.hpp"
#include "strata/planner.hpp"

namespace strata::server {

class MapCache {
 public:
  using Loader = std::function<Result<std::shared_ptr<const PlanningMap>>()>;

  /// `budget_bytes` 0: no limit.
  explicit MapCache(std::uint64_t budget_bytes) : budget_bytes_(budget_bytes) {}

  /// The planning map of version `version` of map `id`: held already, or made by `load`
  /// (outside the lock). Concurrent callers for one version wait for the same load and share
  /// its outcome; a failed load is not remembered. After a load, the least recently used maps
  /// no caller holds are dropped until the held bytes fit the budget; a map that alone needs
  /// more than the budget is not kept and fails with kResourceExhausted.
  Result<std::shared_ptr<const PlanningMap>> Get(const std::string& id, const std::string& version,
                                                 const Loader& load);

  /// Holds a map made here (a map just created or edited on this server), as Get would.
  void Insert(const std::string& id, const std::string& version,
              std::shared_ptr<const PlanningMap> map);

  /// Forgets every version of `id` (deleted from the store).
  void Drop(const std::string& id);

  /// The version of `id` held, if one is (the most recently used).
  std::shared_ptr<const PlanningMap> Peek(const std::string& id, const std::string& version) const;

  /// Bytes of the maps held (their models and the graphs built on them so far).
  std::uint64_t ResidentBytes() const;
  /// Versions held.
  int Count() const;
  std::uint64_t budget_bytes() const { return budget_bytes_; }

 private:
  using Key = std::pair<std::string, std::string>;  // Map id, version.
  struct Slot {
    std::shared_ptr<const PlanningMap> map;  // Null while loading.
    bool loading = false;
    std::list<Key>::iterator recency;  // In recency_ once loaded.
  };

  // Drops least recently used maps nobody else holds until the bytes fit; call with mutex_.
  void EvictLocked();
  void TouchLocked(Slot& slot, const Key& key);

  const std::uint64_t budget_bytes_;
  mutable std::mutex mutex_;
  std::condition_variable loaded_;  // A load finished (or failed).
  std::map<Key, Slot> slots_;
  std::list<Key> recency_;  // Most recently used first.
};

}  // namespace strata::server
