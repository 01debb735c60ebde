#pragma once
/// The map versions a server holds in memory when its maps live in a map store
/// (map_store.hpp): loaded on demand, once, and dropped least recently used first when their
/// bytes pass what the server's memory budget leaves them (memory_budget.hpp). Dropping only
/// forgets the map here; the store keeps it, and a plan holding it finishes on it (it is freed when
/// that plan lets go). No gRPC here.
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "common/service_error.hpp"
#include "strata/planner.hpp"

namespace strata::server {

class MapCache {
 public:
  using Loader = std::function<Result<std::shared_ptr<const PlanningMap>>()>;
  /// The bytes the maps held may take now (MemoryBudget::MapAllowance); it may change
  /// between calls, and is asked with the cache's lock held.
  using Allowance = std::function<std::uint64_t()>;

  /// Without an allowance, maps are never dropped for room.
  explicit MapCache(Allowance allowance = {}) : allowance_(std::move(allowance)) {}

  /// The planning map of version `version` of map `id`: held already, or made by `load`
  /// (outside the lock). Concurrent callers for one version wait for the same load and share
  /// its outcome; a failed load is not remembered. After a load, the least recently used maps
  /// no caller holds are dropped until the held bytes fit the allowance; a map that alone
  /// needs more than the allowance is not kept and fails with kResourceExhausted.
  Result<std::shared_ptr<const PlanningMap>> Get(const std::string& id, const std::string& version,
                                                 const Loader& load);

  /// Holds a map made here (a map just created or edited on this server) before its version
  /// is published, as Get would, keeping the other versions of `id`: the first requests for
  /// the new head then find it, with the graphs built ahead for it, instead of loading its
  /// saved model from the store while it is published (a second copy of a site's model, and
  /// a map without graphs for the next edit to build on). Returns whether the version was not
  /// held before. A load of the version under way keeps this map instead of its own.
  bool Hold(const std::string& id, const std::string& version,
            std::shared_ptr<const PlanningMap> map);

  /// Version `version` of `id`, held (Hold), is now published: forgets the other versions of
  /// `id` held, since the one made is the current one. A map that robots' scans edit every
  /// second so holds one version, not every one made until the budget is full. A plan holding
  /// an older version finishes on it; a later request for one (PlanRequest.map_version) loads
  /// it again from the store.
  void MarkPublished(const std::string& id, const std::string& version);

  /// Forgets version `version` of `id` unless it is being loaded: a version held (Hold) whose
  /// publishing failed.
  void Forget(const std::string& id, const std::string& version);

  /// Forgets every version of `id` (deleted from the store).
  void Drop(const std::string& id);

  /// Drops the least recently used maps no caller holds until the maps held take at most
  /// `target_bytes` (or none is left to drop): to make room for other uses of memory.
  void TrimTo(std::uint64_t target_bytes);

  /// The version of `id` held, if one is (the most recently used); a map made here for a
  /// version being loaded (Hold) counts as held.
  std::shared_ptr<const PlanningMap> Peek(const std::string& id, const std::string& version) const;

  /// Bytes of the maps held (their models and the graphs built on them so far).
  std::uint64_t ResidentBytes() const;
  /// Versions held.
  int Count() const;

 private:
  using Key = std::pair<std::string, std::string>;  // Map id, version.
  struct Slot {
    std::shared_ptr<const PlanningMap> map;  // Null while loading.
    bool loading = false;
    std::shared_ptr<const PlanningMap> made;  // Held while loading: kept instead.
    std::list<Key>::iterator recency;         // In recency_ once loaded.
  };

  // Drops least recently used maps nobody else holds until they take at most `target`
  // bytes, never the most recently used one when `keep_newest`; call with mutex_.
  void EvictLocked(std::uint64_t target, bool keep_newest);
  // Forgets the versions of `id` held but `kept` (all when it is empty), except those being
  // loaded (their loaders find their slots); call with mutex_.
  void DropLocked(const std::string& id, const std::string& kept);
  // The allowance now (no limit without one).
  std::uint64_t AllowanceBytes() const;
  void TouchLocked(Slot& slot, const Key& key);
  // Hold's work, without notifying; call with mutex_. Whether the version was not held.
  bool HoldLocked(const std::string& id, const std::string& version,
                  std::shared_ptr<const PlanningMap> map);

  const Allowance allowance_;
  mutable std::mutex mutex_;
  std::condition_variable loaded_;  // A load finished (or failed).
  std::map<Key, Slot> slots_;
  std::list<Key> recency_;  // Most recently used first.
};

}  // namespace strata::server
