#pragma once
/// The published maps of a server without a map store: each map's one version, in this
/// process's memory, until the map is deleted. Edits need a store (kMapStoreRequired). No
/// gRPC here.
#include <map>
#include <mutex>

#include "maps/published_maps.hpp"

namespace strata::server {

class MemoryMaps final : public PublishedMaps {
 public:
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
  bool KeepsClouds() const override { return false; }
  Result<VersionFiles> OpenFiles(const std::string& id, const std::string& version) const override;
  Result<PointCloud> LoadCloud(const std::string& id, const std::string& version) const override;
  std::uint64_t HeldBytes() const override;
  int HeldCount() const override;
  int PinnedCount() const override { return HeldCount(); }
  void TrimTo(std::uint64_t /*target_bytes*/) override {}  // Nothing here could be loaded again.

 private:
  struct Published {
    MapSnapshot map;
    std::shared_ptr<const PlanningMap> planning;
  };

  mutable std::mutex mutex_;
  std::map<std::string, Published> maps_;
};

}  // namespace strata::server
