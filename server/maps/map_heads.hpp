#pragma once
/// Where a map store's heads live when they are not files in its directory: the head pointer
/// and the kept versions of each map, shared by every replica (etcd, --etcd:
/// server/shared/etcd_map_heads.hpp). The versions themselves stay in the store's directory.
/// No gRPC here.
#include <optional>
#include <string>
#include <vector>

#include "common/service_error.hpp"

namespace strata::server {

class MapHeads {
 public:
  /// A map's kept versions, newest (current) first; nullopt when there is no such map.
  using Head = std::optional<std::vector<std::string>>;

  virtual ~MapHeads() = default;

  /// `id`'s head as this replica knows it now. kMapStoreUnavailable when the heads cannot be
  /// known (never read yet, the shared store unreachable since the start).
  virtual Result<Head> Read(const std::string& id) const = 0;
  /// Every map's id, in byte order; fails as Read does.
  virtual Result<std::vector<std::string>> Ids() const = 0;
  /// Makes `id`'s head `next` (nullopt: the map is deleted) if it is still `expected`;
  /// false when it was not (Read then tells the current one). kMapStoreUnavailable when the
  /// shared store cannot be reached.
  virtual Result<bool> Swap(const std::string& id, const Head& expected, const Head& next) = 0;
};

}  // namespace strata::server
