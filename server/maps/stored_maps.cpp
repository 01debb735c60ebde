#include "maps/stored_maps.hpp"

#include <utility>

#include "common/log.hpp"

namespace strata::server {

StoredMaps::StoredMaps(StoredMapsOptions options)
    : options_(std::move(options)), cache_(options_.allowance) {}

Result<std::vector<std::string>> StoredMaps::Versions(const std::string& id) const {
  Result<std::vector<std::string>> versions = options_.store->Versions(id);
  if (!versions.ok() || versions.value().empty()) {
    cache_.Drop(id);  // Deleted, perhaps by another replica: free it here too.
    return MapNotFound(id).Blame("map_id");
  }
  return versions;
}

Result<ActiveMap> StoredMaps::Get(const std::string& id, const std::string& version) const {
  Result<std::vector<std::string>> versions = Versions(id);
  if (!versions.ok()) return std::move(versions).error();
  if (version.empty() && cache_.Peek(id, versions.value().front()) == nullptr) {
    // The head read may be gone by now: a version is held before its head names it (Put), and
    // the one before is dropped once it does. Read again rather than load a version that is
    // no longer the head (on a site, seconds: its tiles and its graphs from the store; 3 to 4
    // plans in 5 minutes of scans waited 3-7 s so).
    versions = Versions(id);
    if (!versions.ok()) return std::move(versions).error();
  }
  const std::vector<std::string>& kept = versions.value();
  if (!version.empty() && std::find(kept.begin(), kept.end(), version) == kept.end()) {
    return MapVersionNotFound(id, version, kept);
  }
  const std::string& wanted = version.empty() ? kept.front() : version;
  bool loaded = false;
  std::shared_ptr<const PlanningMap> made_from;  // The held version a load shares parts of.
  Result<std::shared_ptr<const PlanningMap>> map =
      cache_.Get(id, wanted, [&]() -> Result<std::shared_ptr<const PlanningMap>> {
        loaded = true;
        Result<std::string> metadata = options_.store->LoadMetadata(id, wanted);
        if (!metadata.ok()) return std::move(metadata).error();
        Result<MapSnapshot> described = options_.decode_metadata(metadata.value());
        if (!described.ok()) return std::move(described).error();
        Result<std::string> terrain = options_.store->TerrainOfVersion(id, wanted);
        if (!terrain.ok()) return std::move(terrain).error();
        // A version of a terrain held here already (keep-out zones changed, perhaps on another
        // replica): the held map with this version's zones, its model and graphs shared.
        if (std::shared_ptr<const PlanningMap> same = HeldOfTerrain(id, kept, terrain.value())) {
          made_from = same;
          return same->WithKeepOut(described.value().keep_out);
        }
        // Another version held here (the one before, on a replica that planned on it): the
        // tiles the two share are taken from its model, and only the changed ones read.
        std::shared_ptr<const PlanningMap> other;
        std::string other_version;
        for (const std::string& version : kept) {
          if (version == wanted) continue;
          if ((other = cache_.Peek(id, version))) {
            other_version = version;
            break;
          }
        }
        std::optional<CellBox> changed;
        Result<std::shared_ptr<const TerrainModel>> model = options_.store->LoadModel(
            id, wanted, other ? other->model_ptr() : nullptr, other_version, &changed);
        if (!model.ok()) return std::move(model).error();
        std::shared_ptr<const PlanningMap> planning = options_.make_planning(
            std::move(model).value(), described.value().keep_out, id, terrain.value());
        // The robots that planned on the other version get their graphs patched from its, as
        // the editor does: not built (a tenth of the time on a site), nor loaded from the store
        // where the editing replica kept them (a patch is faster than a load too).
        if (changed) planning->MakeGraphsAhead(*other, &*changed, kMaxGraphsBuiltAhead);
        made_from = std::move(other);
        return planning;
      });
  if (loaded) {
    if (map.ok() && version.empty()) ForgetBeforeHead(id, wanted);
    // The load's scratch (a site's tiles), and the versions it made the cache drop; room for
    // the next load's new arrays stays free for it. A version loaded beside the one before
    // (a replica following another's edits) is new only where it does not share that one's
    // parts: counting it whole kept a 1 km site's 2.7 GB free for a load that wants 0.8 GB.
    if (options_.free_memory != nullptr) {
      options_.free_memory->Request(map.ok() ? map.value()->MemoryBytesBeyond(made_from.get()) : 0);
    }
  }
  if (!map.ok()) return std::move(map).error();
  return ActiveMap{std::move(map).value(), wanted};
}

void StoredMaps::ForgetBeforeHead(const std::string& id, const std::string& head) const {
  // A replica that follows another's edits loads each head it plans on; without this it would
  // hold every version until the memory budget dropped them (and with no budget, forever).
  // Checked again after the load: a newer head loaded meanwhile must not be the one forgotten.
  const Result<std::vector<std::string>> now = options_.store->Versions(id);
  if (!now.ok() || now.value().empty() || now.value().front() != head) return;
  cache_.MarkPublished(id, head);
}

std::shared_ptr<const PlanningMap> StoredMaps::HeldOfTerrain(
    const std::string& id, const std::vector<std::string>& versions,
    const std::string& terrain) const {
  if (terrain.empty()) return nullptr;  // Layout 1: each version its own model.
  for (const std::string& version : versions) {
    std::shared_ptr<const PlanningMap> held = cache_.Peek(id, version);
    if (held == nullptr) continue;
    const Result<std::string> its = options_.store->TerrainOfVersion(id, version);
    if (its.ok() && its.value() == terrain) return held;
  }
  return nullptr;
}

std::shared_ptr<const PlanningMap> StoredMaps::Held(const std::string& id,
                                                    const std::string& version) const {
  return cache_.Peek(id, version);
}

Result<MapSnapshot> StoredMaps::SnapshotOf(const std::string& id,
                                           const std::vector<std::string>& versions) const {
  Result<std::string> metadata = options_.store->LoadMetadata(id, versions.front());
  if (!metadata.ok()) return std::move(metadata).error();
  Result<MapSnapshot> snapshot = options_.decode_metadata(metadata.value());
  if (!snapshot.ok()) return snapshot;
  MapSnapshot& map = snapshot.value();
  map.id = id;
  map.version = versions.front();
  map.versions = versions;
  if (const auto held = cache_.Peek(id, map.version)) map.memory_bytes = held->MemoryBytes();
  return snapshot;
}

Result<MapSnapshot> StoredMaps::Describe(const std::string& id) const {
  Result<std::vector<std::string>> versions = Versions(id);
  if (!versions.ok()) return std::move(versions).error();
  return SnapshotOf(id, versions.value());
}

std::vector<MapSnapshot> StoredMaps::List(const std::string& after_id, int max) const {
  std::vector<MapSnapshot> maps;
  Result<std::vector<std::string>> ids = options_.store->ListIds(after_id, max);
  for (const std::string& id : ids.ok() ? ids.value() : std::vector<std::string>{}) {
    Result<std::vector<std::string>> versions = options_.store->Versions(id);
    if (!versions.ok() || versions.value().empty()) continue;  // Deleted meanwhile.
    Result<MapSnapshot> snapshot = SnapshotOf(id, versions.value());
    if (snapshot.ok()) maps.push_back(std::move(snapshot).value());
  }
  return maps;
}

ServiceStatus StoredMaps::Put(const MapSnapshot& map, const std::string& terrain,
                              const std::shared_ptr<const PlanningMap>& planning,
                              const CutTerrain* tiles, TileWrites* writes,
                              const std::function<ServiceStatus()>& publish) {
  LogInfo("map_version_writing").Add("map", map.id).Add("version", map.version);
  MapStore& store = *options_.store;
  if (tiles != nullptr) {
    if (ServiceStatus put = store.PutTerrain(map.id, terrain, *tiles, writes); !put.ok()) {
      return put;
    }
  }
  if (ServiceStatus put =
          store.PutVersion(map.id, map.version, terrain, options_.encode_metadata(map));
      !put.ok()) {
    return put;
  }
  // Held before the head names it: the first requests for it find it here (MapCache::Hold).
  const bool held_here = cache_.Hold(map.id, map.version, planning);
  if (ServiceStatus published = publish(); !published.ok()) {
    if (held_here) cache_.Forget(map.id, map.version);
    return published;
  }
  cache_.MarkPublished(map.id, map.version);
  return OkStatus();
}

ServiceStatus StoredMaps::PublishNew(const MapSnapshot& map,
                                     std::shared_ptr<const PlanningMap> planning,
                                     const PointCloud& cloud) {
  // A new map has no keep-out zones: its version names its terrain (MapStore::VersionOf).
  const CutTerrain tiles = CutIntoTiles(planning->model(), cloud);
  return Put(map, map.version, planning, &tiles, nullptr,
             [&] { return options_.store->PublishNew(map.id, map.version); });
}

ServiceStatus StoredMaps::PublishEdit(const std::string& base_version, const MapSnapshot& map,
                                      const std::string& terrain,
                                      std::shared_ptr<const PlanningMap> planning,
                                      const CutTerrain* tiles, TileWrites* writes) {
  return Put(map, terrain, planning, tiles, writes, [&] {
    return options_.store->PublishUpdate(map.id, base_version, map.version, options_.versions_kept);
  });
}

ServiceStatus StoredMaps::PutTerrain(const std::string& id, const std::string& terrain,
                                     const CutTerrain& tiles, TileWrites* writes) {
  return options_.store->PutTerrain(id, terrain, tiles, writes);
}

Result<std::string> StoredMaps::TerrainOf(const std::string& id, const std::string& version) const {
  return options_.store->TerrainOfVersion(id, version);
}

ServiceStatus StoredMaps::Delete(const std::string& id) {
  cache_.Drop(id);
  return options_.store->Delete(id);
}

Result<VersionFiles> StoredMaps::OpenFiles(const std::string& id,
                                           const std::string& version) const {
  return options_.store->OpenVersion(id, version);
}

Result<PointCloud> StoredMaps::LoadCloud(const std::string& id, const std::string& version) const {
  return options_.store->LoadCloud(id, version);
}

std::uint64_t StoredMaps::HeldBytes() const { return cache_.ResidentBytes(); }

int StoredMaps::HeldCount() const { return cache_.Count(); }

void StoredMaps::TrimTo(std::uint64_t target_bytes) { cache_.TrimTo(target_bytes); }

}  // namespace strata::server
