#pragma once
/// The published maps of a server with a map store (--map-store): every version lives in the
/// store shared by all replicas (map_store.hpp), and the versions planned on here are loaded
/// into a cache within the server's memory budget (map_cache.hpp). Every request reads the
/// map's head from the store, so a map updated or deleted on another replica is seen at once.
/// No gRPC here.
#include <functional>
#include <memory>

#include "common/free_memory.hpp"
#include "maps/map_cache.hpp"
#include "maps/map_store.hpp"
#include "maps/published_maps.hpp"

namespace strata::server {

struct StoredMapsOptions {
  std::shared_ptr<MapStore> store;  ///< Required.
  /// Versions kept per map, the current one included [-], >= 1.
  int versions_kept = 5;
  /// How a version's description is written beside it and read back (the server stores the
  /// API's Map message: proto_convert.hpp). Both required.
  std::function<std::string(const MapSnapshot&)> encode_metadata;
  std::function<Result<MapSnapshot>(const std::string&)> decode_metadata;
  /// The planning map of a model loaded from the store, with the version's keep-out zones.
  PlanningMaker make_planning;
  /// The bytes the loaded versions may take (MapCache::Allowance); empty: no bound.
  MapCache::Allowance allowance;
  /// Told after each load of a version (its scratch, and the versions it made the cache
  /// forget, are free): may be null.
  FreeMemoryReturner::Room* free_memory = nullptr;
};

class StoredMaps final : public PublishedMaps {
 public:
  explicit StoredMaps(StoredMapsOptions options);

  Result<std::vector<std::string>> Versions(const std::string& id) const override;
  Result<ActiveMap> Get(const std::string& id, const std::string& version) const override;
  std::shared_ptr<const PlanningMap> Held(const std::string& id,
                                          const std::string& version) const override;
  Result<MapSnapshot> Describe(const std::string& id) const override;
  std::vector<MapSnapshot> List(const std::string& after_id, int max) const override;
  ServiceStatus PublishNew(const MapSnapshot& map, std::shared_ptr<const PlanningMap> planning,
                           const PointCloud& cloud) override;
  ServiceStatus PublishEdit(const std::string& base_version, const MapSnapshot& map,
                            const std::string& terrain, std::shared_ptr<const PlanningMap> planning,
                            const CutTerrain* tiles, TileWrites* writes) override;
  ServiceStatus PutTerrain(const std::string& id, const std::string& terrain,
                           const CutTerrain& tiles, TileWrites* writes) override;
  Result<std::string> TerrainOf(const std::string& id, const std::string& version) const override;
  ServiceStatus Delete(const std::string& id) override;
  bool KeepsClouds() const override { return true; }
  Result<VersionFiles> OpenFiles(const std::string& id, const std::string& version) const override;
  Result<PointCloud> LoadCloud(const std::string& id, const std::string& version) const override;
  std::uint64_t HeldBytes() const override;
  int HeldCount() const override;
  int PinnedCount() const override { return 0; }
  void TrimTo(std::uint64_t target_bytes) override;

  const MapStore& store() const { return *options_.store; }

 private:
  // After a load of the head `head` of `id`: forgets the other versions held here, as an
  // editing replica does once it publishes (MapCache::MarkPublished), while `head` is still
  // the head.
  void ForgetBeforeHead(const std::string& id, const std::string& head) const;
  // A planning map of one of `versions` of `id` held here whose terrain is `terrain`, or null.
  std::shared_ptr<const PlanningMap> HeldOfTerrain(const std::string& id,
                                                   const std::vector<std::string>& versions,
                                                   const std::string& terrain) const;
  // The snapshot `metadata` of `id` describes, at `versions.front()`.
  Result<MapSnapshot> SnapshotOf(const std::string& id,
                                 const std::vector<std::string>& versions) const;
  // Writes the version of `map`, made of `terrain` (and that too from `tiles` unless they are
  // null: the store holds it), and caches `planning` once `publish` made it visible.
  ServiceStatus Put(const MapSnapshot& map, const std::string& terrain,
                    const std::shared_ptr<const PlanningMap>& planning, const CutTerrain* tiles,
                    TileWrites* writes, const std::function<ServiceStatus()>& publish);

  StoredMapsOptions options_;
  // The versions loaded here (mutable: loading on demand is not a change).
  mutable MapCache cache_;
};

}  // namespace strata::server
