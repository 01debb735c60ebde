#pragma once
/// Bearer tokens with roles (--auth-tokens FILE): who may plan and who may change maps.
/// No gRPC here: the services pass the call's `authorization` metadata to Authorize.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "service_error.hpp"

namespace strata::server {

/// What a token allows. kPlanner: Plan, ListRecentPlans, GetMap, GetMapGeometry, ListMaps
/// (every call that changes nothing) and the web viewer's API, which offers only those.
/// kAdmin: those and CreateMap, UploadMap, UpdateMap, DeleteMap.
enum class Role { kPlanner, kAdmin };

/// The tokens a server accepts, read once at start.
class TokenTable {
 public:
  /// Reads `path`: one `TOKEN ROLE` per line (ROLE `planner` or `admin`), blank lines and
  /// lines starting with '#' ignored. A token is 16 to 256 printable characters without
  /// spaces. Fails with kInvalidInput naming the file and line (never quoting a token: the
  /// message goes to the log), or when the file holds no token.
  static Result<TokenTable> Load(const std::filesystem::path& path);

  /// A table of `entries` (tests).
  explicit TokenTable(std::vector<std::pair<std::string, Role>> entries)
      : entries_(std::move(entries)) {}

  /// Checks `authorization` (the call's "authorization" metadata, "Bearer TOKEN"; empty when
  /// absent) for `needed`: kUnauthenticated when missing, malformed or unknown,
  /// kPermissionDenied when the token's role is not enough. Every token is compared in full,
  /// in constant time, so a reply's timing tells nothing about how much of a guess matched.
  ServiceStatus Authorize(std::string_view authorization, Role needed) const;

  std::size_t size() const { return entries_.size(); }

 private:
  std::vector<std::pair<std::string, Role>> entries_;
};

/// "planner" or "admin".
const char* RoleName(Role role);

}  // namespace strata::server
