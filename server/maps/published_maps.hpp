#pragma once
/// The maps made and published: for each id the versions kept, the current one first, and the
/// planning map of any of them. A map being made lives in the registry until it is published
/// here; what is published is ACTIVE. Two homes, one interface: this process's memory
/// (MemoryMaps, a server without --map-store) and the map store shared by every replica, with
/// the versions loaded here kept in a cache (StoredMaps). No gRPC here.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/service_error.hpp"
#include "maps/map_root.hpp"
#include "maps/map_snapshot.hpp"
#include "maps/map_store.hpp"
#include "strata/point_cloud.hpp"

namespace strata::server {

/// Most robots' graphs made ahead for a new terrain (an edit's, or one a replica loads beside
/// the version before), those the version before had: each costs a tenth of a second to a
/// second on a 400 m site, and a map may hold one per inline profile.
inline constexpr std::size_t kMaxGraphsBuiltAhead = 4;

/// Makes the planning map of `model`, terrain `terrain` of map `id` (empty: a version of
/// layout 1, which has no terrain of its own), with `keep_out`.
using PlanningMaker = std::function<std::shared_ptr<const PlanningMap>(
    std::shared_ptr<const TerrainModel> model, std::vector<Prism> keep_out, const std::string& id,
    const std::string& terrain)>;

class PublishedMaps {
 public:
  virtual ~PublishedMaps() = default;

  /// The versions of `id` kept, newest (current) first; kMapNotFound blaming "map_id".
  virtual Result<std::vector<std::string>> Versions(const std::string& id) const = 0;

  /// The planning map of `version` of `id` (empty: the current one), loaded when not held;
  /// kMapNotFound, kMapVersionNotFound naming the versions kept, or why it cannot be loaded.
  virtual Result<ActiveMap> Get(const std::string& id, const std::string& version) const = 0;
  /// Version `version` of map `id` if this server holds it in memory now, else null: never
  /// loads it.
  virtual std::shared_ptr<const PlanningMap> Held(const std::string& id,
                                                  const std::string& version) const = 0;

  /// The current version's snapshot (ACTIVE, with its versions, and its memory when held);
  /// kMapNotFound.
  virtual Result<MapSnapshot> Describe(const std::string& id) const = 0;

  /// The snapshots of up to `max` (>= 1) maps with ids greater than `after_id`, in id order.
  virtual std::vector<MapSnapshot> List(const std::string& after_id, int max) const = 0;

  /// Publishes `map` (ACTIVE, version set) as the first version of map `map.id`, holding
  /// `planning`; `cloud` is kept when versions keep clouds. Success also when the map is
  /// published with that very version (another replica made the same map);
  /// kMapAlreadyExists when it is published with another.
  virtual ServiceStatus PublishNew(const MapSnapshot& map,
                                   std::shared_ptr<const PlanningMap> planning,
                                   const PointCloud& cloud) = 0;

  /// Publishes `map` (version set) as the new current version of `map.id` if the current one
  /// is still `base_version` (compare-and-swap), keeping the newest versions; kMapChanged
  /// naming the current version otherwise (nothing of this edit is left behind), or
  /// kMapStoreRequired where versions keep no clouds. `terrain` names what the version is
  /// made of (MapStore::TerrainOf: the cloud and the model `planning` holds); `tiles` is that
  /// terrain cut into tiles (MapStore::PutTerrain: an edit's names the base's tiles it kept), or
  /// null when the terrain is the base version's (an edit of keep-out zones alone): then only
  /// the version's description is written. `writes` (may be null) gets what writing the
  /// terrain cost.
  virtual ServiceStatus PublishEdit(const std::string& base_version, const MapSnapshot& map,
                                    const std::string& terrain,
                                    std::shared_ptr<const PlanningMap> planning,
                                    const CutTerrain* tiles, TileWrites* writes) = 0;

  /// Writes `terrain` of `id`, cut into `tiles`, before a version names it (PublishEdit does
  /// when it is not there yet): an edit writes it while the version's graphs are made.
  /// `writes` (may be null) gets what it cost; kMapStoreRequired where versions keep no clouds.
  virtual ServiceStatus PutTerrain(const std::string& id, const std::string& terrain,
                                   const CutTerrain& tiles, TileWrites* writes) = 0;

  /// The terrain `version` of `id` is made of (MapStore::TerrainOf), or empty when that is
  /// not known (a version a store of layout 1 wrote): an edit of its keep-out zones then
  /// passes the cloud on again. Fails as Get.
  virtual Result<std::string> TerrainOf(const std::string& id,
                                        const std::string& version) const = 0;

  /// Removes every version of `id`; kMapNotFound.
  virtual ServiceStatus Delete(const std::string& id) = 0;

  /// Whether versions keep their source clouds, which edits start from.
  virtual bool KeepsClouds() const = 0;
  /// The cloud and model files of `version` of `id`, opened; fails as Get.
  virtual Result<VersionFiles> OpenFiles(const std::string& id,
                                         const std::string& version) const = 0;
  /// The source cloud of `version` of `id`; fails as Get.
  virtual Result<PointCloud> LoadCloud(const std::string& id, const std::string& version) const = 0;

  /// Bytes of the planning maps held in memory, how many versions they are, and dropping
  /// those no plan holds (least recently used first) until at most `target_bytes` are held,
  /// where a map can be loaded again.
  virtual std::uint64_t HeldBytes() const = 0;
  virtual int HeldCount() const = 0;
  virtual void TrimTo(std::uint64_t target_bytes) = 0;
  /// Maps held that cannot be let go and loaded again (they count against --max-maps).
  virtual int PinnedCount() const = 0;
};

/// kMapStoreRequired: `id` cannot be edited without a map store.
ServiceError MapStoreRequired(const std::string& id);
/// kMapNotFound for `id`, naming ListMaps.
ServiceError MapNotFound(const std::string& id);
/// kMapVersionNotFound for `version` of `id`, naming the versions `kept`.
ServiceError MapVersionNotFound(const std::string& id, const std::string& version,
                                const std::vector<std::string>& kept);

}  // namespace strata::server
