#include "common/map_id.hpp"

#include <algorithm>

namespace strata::server {
namespace {

bool IsIdCharacter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

}  // namespace

ServiceStatus ValidateMapId(const std::string& id) {
  const bool well_formed = !id.empty() && id.size() <= kMaxMapIdLength && id != "." && id != ".." &&
                           std::all_of(id.begin(), id.end(), IsIdCharacter);
  if (well_formed) return OkStatus();
  std::string shown = id.substr(0, kMaxMapIdLength);
  std::replace_if(
      shown.begin(), shown.end(), [](char c) { return !IsIdCharacter(c); }, '?');
  return MakeError(ErrorCode::kInvalidInput,
                   "map id '" + shown + (id.size() > kMaxMapIdLength ? "...'" : "'") +
                       " is not valid: use 1 to 64 characters from A-Z a-z 0-9 . _ - (not '.' "
                       "or '..')")
      .Blame("map_id");
}

ServiceStatus RequireMapId(const std::string& id) {
  if (!id.empty()) return OkStatus();
  return MakeError(ErrorCode::kInvalidInput, "map_id is required (ListMaps shows the maps)")
      .Blame("map_id");
}

}  // namespace strata::server
