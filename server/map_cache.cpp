#include "map_cache.hpp"

#include <vector>

namespace strata::server {

void MapCache::TouchLocked(Slot& slot, const Key& key) {
  if (slot.map != nullptr) recency_.erase(slot.recency);
  recency_.push_front(key);
  slot.recency = recency_.begin();
}

Result<std::shared_ptr<const PlanningMap>> MapCache::Get(const std::string& id,
                                                         const std::string& version,
                                                         const Loader& load) {
  const Key key(id, version);
  std::unique_lock lock(mutex_);
  while (true) {
    auto it = slots_.find(key);
    if (it == slots_.end()) break;
    if (it->second.map != nullptr) {
      TouchLocked(it->second, key);
      return it->second.map;
    }
    // Another caller is loading it: share its outcome (or, if that load fails, try again).
    loaded_.wait(lock);
  }
  slots_[key].loading = true;
  lock.unlock();

  Result<std::shared_ptr<const PlanningMap>> loaded = [&]() {
    try {
      return load();
    } catch (const std::bad_alloc&) {
      return Result<std::shared_ptr<const PlanningMap>>(MakeError(
          ErrorCode::kResourceExhausted, "the server ran out of memory loading map '" + id +
                                             "': lower --max-map-memory or give it more memory"));
    }
  }();

  lock.lock();
  auto it = slots_.find(key);
  if (!loaded.ok()) {
    slots_.erase(it);
    lock.unlock();
    loaded_.notify_all();
    return loaded;
  }
  const std::shared_ptr<const PlanningMap> map = std::move(loaded).value();
  const std::uint64_t bytes = map->MemoryBytes();
  if (budget_bytes_ > 0 && bytes > budget_bytes_) {
    slots_.erase(it);
    lock.unlock();
    loaded_.notify_all();
    return MakeError(ErrorCode::kResourceExhausted,
                     "map '" + id + "' needs " + std::to_string(bytes) +
                         " bytes, more than this server's --max-map-memory of " +
                         std::to_string(budget_bytes_) + ": raise it")
        .With("map_id", id);
  }
  it->second.loading = false;
  it->second.map = map;
  recency_.push_front(key);
  it->second.recency = recency_.begin();
  EvictLocked();
  lock.unlock();
  loaded_.notify_all();
  return map;
}

void MapCache::Insert(const std::string& id, const std::string& version,
                      std::shared_ptr<const PlanningMap> map) {
  const Key key(id, version);
  {
    std::lock_guard lock(mutex_);
    Slot& slot = slots_[key];
    if (slot.loading) return;  // A load of the same version is under way; it will hold it.
    TouchLocked(slot, key);
    slot.map = std::move(map);
    EvictLocked();
  }
  loaded_.notify_all();
}

void MapCache::Drop(const std::string& id) {
  std::lock_guard lock(mutex_);
  for (auto it = slots_.lower_bound(Key(id, "")); it != slots_.end() && it->first.first == id;) {
    if (it->second.loading) {  // Its loader will find the slot; let it finish.
      ++it;
      continue;
    }
    recency_.erase(it->second.recency);
    it = slots_.erase(it);
  }
}

std::shared_ptr<const PlanningMap> MapCache::Peek(const std::string& id,
                                                  const std::string& version) const {
  std::lock_guard lock(mutex_);
  const auto it = slots_.find(Key(id, version));
  return it == slots_.end() ? nullptr : it->second.map;
}

void MapCache::EvictLocked() {
  if (budget_bytes_ == 0 || recency_.empty()) return;
  std::uint64_t bytes = 0;
  for (const auto& [key, slot] : slots_) {
    if (slot.map != nullptr) bytes += slot.map->MemoryBytes();
  }
  // Oldest first; the newest (just loaded or used) is never dropped for its own room.
  for (auto it = std::prev(recency_.end()); bytes > budget_bytes_ && it != recency_.begin();) {
    const auto slot = slots_.find(*it);
    const auto older = std::prev(it);
    // use_count 1: only this cache holds it, so no plan runs on it and dropping frees it.
    if (slot->second.map.use_count() == 1) {
      bytes -= slot->second.map->MemoryBytes();
      recency_.erase(it);
      slots_.erase(slot);
    }
    it = older;
  }
}

std::uint64_t MapCache::ResidentBytes() const {
  std::lock_guard lock(mutex_);
  std::uint64_t bytes = 0;
  for (const auto& [key, slot] : slots_) {
    if (slot.map != nullptr) bytes += slot.map->MemoryBytes();
  }
  return bytes;
}

int MapCache::Count() const {
  std::lock_guard lock(mutex_);
  int count = 0;
  for (const auto& [key, slot] : slots_) count += slot.map != nullptr ? 1 : 0;
  return count;
}

}  // namespace strata::server
