#include "maps/map_cache.hpp"

#include <limits>
#include <vector>

#include "common/log.hpp"
#include "maps/memory_budget.hpp"

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
                                             "': lower --max-memory or give it more memory"));
    }
  }();

  lock.lock();
  auto it = slots_.find(key);
  // A map made here while this load ran (Hold: a version just published, which a request
  // asked for before it was held) is the one kept: it holds the graphs built ahead for it.
  if (it->second.made != nullptr) loaded = std::move(it->second.made);
  if (!loaded.ok()) {
    slots_.erase(it);
    lock.unlock();
    loaded_.notify_all();
    return loaded;
  }
  const std::shared_ptr<const PlanningMap> map = std::move(loaded).value();
  const std::uint64_t bytes = map->MemoryBytes();
  if (const std::uint64_t allowance = AllowanceBytes(); bytes > allowance) {
    slots_.erase(it);
    lock.unlock();
    loaded_.notify_all();
    return MakeError(ErrorCode::kResourceExhausted,
                     "map '" + id + "' needs " + MebibytesText(bytes) + ", more than the " +
                         MebibytesText(allowance) +
                         " the server's memory budget leaves for maps now (--max-memory): "
                         "retry when uploads and assessments have finished, or raise it")
        .With("map_id", id);
  }
  it->second.loading = false;
  it->second.map = map;
  recency_.push_front(key);
  it->second.recency = recency_.begin();
  EvictLocked(AllowanceBytes(), /*keep_newest=*/true);
  lock.unlock();
  loaded_.notify_all();
  return map;
}

bool MapCache::HoldLocked(const std::string& id, const std::string& version,
                          std::shared_ptr<const PlanningMap> map) {
  const Key key(id, version);
  const auto [it, added] = slots_.try_emplace(key);
  Slot& slot = it->second;
  if (slot.loading) {  // A load of the same version is under way: it keeps this map instead.
    const bool first = slot.made == nullptr;
    slot.made = std::move(map);
    return first;
  }
  TouchLocked(slot, key);
  slot.map = std::move(map);
  EvictLocked(AllowanceBytes(), /*keep_newest=*/true);
  return added;
}

bool MapCache::Hold(const std::string& id, const std::string& version,
                    std::shared_ptr<const PlanningMap> map) {
  bool added = false;
  {
    std::lock_guard lock(mutex_);
    added = HoldLocked(id, version, std::move(map));
  }
  loaded_.notify_all();
  return added;
}

void MapCache::MarkPublished(const std::string& id, const std::string& version) {
  std::lock_guard lock(mutex_);
  DropLocked(id, version);
}

void MapCache::Forget(const std::string& id, const std::string& version) {
  std::lock_guard lock(mutex_);
  const auto it = slots_.find(Key(id, version));
  if (it == slots_.end() || it->second.loading) return;
  recency_.erase(it->second.recency);
  slots_.erase(it);
}

void MapCache::Drop(const std::string& id) {
  std::lock_guard lock(mutex_);
  DropLocked(id, "");
}

void MapCache::DropLocked(const std::string& id, const std::string& kept) {
  for (auto it = slots_.lower_bound(Key(id, "")); it != slots_.end() && it->first.first == id;) {
    if (it->second.loading || it->first.second == kept) {  // A loader will find its slot.
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
  if (it == slots_.end()) return nullptr;
  return it->second.map != nullptr ? it->second.map : it->second.made;
}

void MapCache::TrimTo(std::uint64_t target_bytes) {
  std::lock_guard lock(mutex_);
  EvictLocked(target_bytes, /*keep_newest=*/false);
}

std::uint64_t MapCache::AllowanceBytes() const {
  return allowance_ ? allowance_() : std::numeric_limits<std::uint64_t>::max();
}

void MapCache::EvictLocked(std::uint64_t target, bool keep_newest) {
  std::uint64_t bytes = 0;
  for (const auto& [key, slot] : slots_) {
    if (slot.map != nullptr) bytes += slot.map->MemoryBytes();
  }
  // Oldest first (recency_ ends with it). For a map just loaded or used (keep_newest), the
  // others make room.
  for (auto it = recency_.end(); bytes > target && it != recency_.begin();) {
    --it;
    if (keep_newest && it == recency_.begin()) break;
    const auto slot = slots_.find(*it);
    // use_count 1: only this cache holds it, so no plan runs on it and dropping frees it.
    if (slot->second.map.use_count() == 1) {
      const std::uint64_t freed = slot->second.map->MemoryBytes();
      bytes -= freed;
      // The next request for it loads it again (seconds for a site's model and graphs): the
      // line that explains such a request's time.
      LogInfo("map_let_go")
          .Add("map", it->first)
          .Add("version", it->second)
          .Add("bytes", freed)
          .Add("allowed_bytes", target);
      slots_.erase(slot);
      it = recency_.erase(it);  // The next older one; the loop steps to the next newer.
    }
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
