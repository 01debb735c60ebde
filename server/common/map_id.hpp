#pragma once
/// The rule for a map's id, the same wherever an id arrives (a request, --preload, a page
/// token, the map store's directories).
#include <string>

#include "common/service_error.hpp"

namespace strata::server {

/// Longest map id [characters].
inline constexpr std::size_t kMaxMapIdLength = 64;

/// Checks that `id` is 1 to 64 characters from [A-Za-z0-9._-] and not "." or ".." (an id
/// names a directory in the map store); kInvalidInput blaming "map_id", quoting the id cut
/// and with its other characters shown as '?', otherwise.
ServiceStatus ValidateMapId(const std::string& id);

/// kInvalidInput blaming "map_id" when a request names no map; OK otherwise (the id itself is
/// looked up, not validated, by the calls that only read).
ServiceStatus RequireMapId(const std::string& id);

}  // namespace strata::server
