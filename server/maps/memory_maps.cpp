#include "maps/memory_maps.hpp"

#include <utility>

namespace strata::server {
Result<std::vector<std::string>> MemoryMaps::Versions(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) return MapNotFound(id).Blame("map_id");
  return std::vector<std::string>{it->second.map.version};
}

Result<ActiveMap> MemoryMaps::Get(const std::string& id, const std::string& version) const {
  std::lock_guard lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) return MapNotFound(id).Blame("map_id");
  const Published& published = it->second;
  if (!version.empty() && version != published.map.version) {
    return MapVersionNotFound(id, version, {published.map.version});
  }
  return ActiveMap{published.planning, published.map.version};
}

std::shared_ptr<const PlanningMap> MemoryMaps::Held(const std::string& id,
                                                    const std::string& version) const {
  std::lock_guard lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end() || it->second.map.version != version) return nullptr;
  return it->second.planning;
}

Result<MapSnapshot> MemoryMaps::Describe(const std::string& id) const {
  std::shared_ptr<const PlanningMap> planning;
  MapSnapshot map;
  {
    std::lock_guard lock(mutex_);
    const auto it = maps_.find(id);
    if (it == maps_.end()) return MapNotFound(id).Blame("map_id");
    map = it->second.map;
    planning = it->second.planning;
  }
  map.memory_bytes = planning->MemoryBytes();  // Outside the lock: it takes the map's own.
  return map;
}

std::vector<MapSnapshot> MemoryMaps::List(const std::string& after_id, int max) const {
  std::vector<std::pair<MapSnapshot, std::shared_ptr<const PlanningMap>>> found;
  {
    std::lock_guard lock(mutex_);
    for (auto it = maps_.upper_bound(after_id);
         it != maps_.end() && static_cast<int>(found.size()) < max; ++it) {
      found.emplace_back(it->second.map, it->second.planning);
    }
  }
  std::vector<MapSnapshot> maps;
  maps.reserve(found.size());
  for (auto& [map, planning] : found) {
    map.memory_bytes = planning->MemoryBytes();
    maps.push_back(std::move(map));
  }
  return maps;
}

ServiceStatus MemoryMaps::PublishNew(const MapSnapshot& map,
                                     std::shared_ptr<const PlanningMap> planning,
                                     const PointCloud& /*cloud*/) {
  std::lock_guard lock(mutex_);
  const auto [it, added] = maps_.try_emplace(map.id, Published{map, std::move(planning)});
  if (added || it->second.map.version == map.version) return OkStatus();
  return MakeError(ServiceErrorCode::kMapAlreadyExists,
                   "map '" + map.id + "' already exists (version " + it->second.map.version +
                       "): delete it first or choose another id")
      .With("map_id", map.id);
}

ServiceStatus MemoryMaps::PublishEdit(const std::string& /*base_version*/, const MapSnapshot& map,
                                      const std::string& /*terrain*/,
                                      std::shared_ptr<const PlanningMap> /*planning*/,
                                      const CutTerrain* /*tiles*/, TileWrites* /*writes*/) {
  return MapStoreRequired(map.id);
}

ServiceStatus MemoryMaps::PutTerrain(const std::string& id, const std::string& /*terrain*/,
                                     const CutTerrain& /*tiles*/, TileWrites* /*writes*/) {
  return MapStoreRequired(id);
}

Result<std::string> MemoryMaps::TerrainOf(const std::string& id,
                                          const std::string& /*version*/) const {
  return MapStoreRequired(id);
}

ServiceStatus MemoryMaps::Delete(const std::string& id) {
  Published gone;  // Freed after the lock (a plan holding it keeps it alive).
  std::lock_guard lock(mutex_);
  const auto it = maps_.find(id);
  if (it == maps_.end()) return MapNotFound(id);
  gone = std::move(it->second);
  maps_.erase(it);
  return OkStatus();
}

Result<VersionFiles> MemoryMaps::OpenFiles(const std::string& id,
                                           const std::string& /*version*/) const {
  return MapStoreRequired(id);
}

Result<PointCloud> MemoryMaps::LoadCloud(const std::string& id,
                                         const std::string& /*version*/) const {
  return MapStoreRequired(id);
}

std::uint64_t MemoryMaps::HeldBytes() const {
  std::vector<std::shared_ptr<const PlanningMap>> held;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, published] : maps_) held.push_back(published.planning);
  }
  std::uint64_t bytes = 0;
  for (const auto& map : held) bytes += map->MemoryBytes();
  return bytes;
}

int MemoryMaps::HeldCount() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(maps_.size());
}

}  // namespace strata::server
