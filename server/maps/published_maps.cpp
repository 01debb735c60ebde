#include "maps/published_maps.hpp"

namespace strata::server {

ServiceError MapStoreRequired(const std::string& id) {
  return MakeError(ServiceErrorCode::kMapStoreRequired,
                   "UpdateMap makes a new version in the map store, and this server has none: "
                   "start it with --map-store DIR")
      .With("map_id", id);
}

ServiceError MapNotFound(const std::string& id) {
  return MakeError(ServiceErrorCode::kMapNotFound,
                   "no map '" + id + "' on this server: ListMaps shows the maps it holds")
      .With("map_id", id);
}

ServiceError MapVersionNotFound(const std::string& id, const std::string& version,
                                const std::vector<std::string>& kept) {
  std::string listed;
  for (const std::string& v : kept) listed += (listed.empty() ? "" : ", ") + v;
  return MakeError(ServiceErrorCode::kMapVersionNotFound,
                   "map '" + id + "' has no version '" + version + "' (kept: " + listed +
                       "): plan on one of those, or leave map_version empty for the current")
      .With("map_id", id)
      .With("map_version", version)
      .Blame("map_version");
}

}  // namespace strata::server
