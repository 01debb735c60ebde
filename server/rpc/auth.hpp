#pragma once
/// Bearer tokens with roles (--auth-tokens FILE): who may plan and who may change maps.
/// No gRPC here: the services pass the call's `authorization` metadata to Authorize.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/service_error.hpp"

namespace strata::server {

/// What a token allows: kPlanner every call that changes no map (kMethodRoles), kAdmin every
/// call.
enum class Role { kPlanner, kAdmin };

/// A method, by its full gRPC name ("/strata.v1.MapService/CreateMap"), and the role it needs.
struct MethodRole {
  std::string_view method;
  Role role;
};

/// Who may call what: the one table that the RPC boundary (rpc_boundary.hpp) and the web
/// viewer's API (http/http_api.hpp) both enforce. Health and reflection need no token.
inline constexpr MethodRole kMethodRoles[] = {
    {"/strata.v1.MapService/CreateMap", Role::kAdmin},
    {"/strata.v1.MapService/UploadMap", Role::kAdmin},
    {"/strata.v1.MapService/UpdateMap", Role::kAdmin},
    {"/strata.v1.MapService/DeleteMap", Role::kAdmin},
    {"/strata.v1.MapService/GetMap", Role::kPlanner},
    {"/strata.v1.MapService/ListMaps", Role::kPlanner},
    {"/strata.v1.MapService/GetMapGeometry", Role::kPlanner},
    {"/strata.v1.PlannerService/Plan", Role::kPlanner},
    {"/strata.v1.PlannerService/PlanBatch", Role::kPlanner},
    {"/strata.v1.PlannerService/EstimateCosts", Role::kPlanner},
    {"/strata.v1.PlannerService/ListRecentPlans", Role::kPlanner},
    // A planner token changes only the reservations it made (ReservationSchedule's owner);
    // an admin one any.
    {"/strata.v1.TrafficService/ReserveTrajectory", Role::kPlanner},
    {"/strata.v1.TrafficService/ReleaseReservation", Role::kPlanner},
    {"/strata.v1.TrafficService/RenewReservation", Role::kPlanner},
    {"/strata.v1.TrafficService/ListReservations", Role::kPlanner},
    {"/strata.v1.TrafficService/ReportProgress", Role::kPlanner},
    {"/strata.v1.TrafficService/WatchSchedule", Role::kPlanner},
};

/// The role `method` (a full gRPC name) needs, or nothing when it is not in kMethodRoles.
std::optional<Role> RoleOf(std::string_view method);

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

  /// Checks `authorization` for the role kMethodRoles gives `method` (a full gRPC name);
  /// kPermissionDenied for a method the table does not list (nobody may call it).
  ServiceStatus AuthorizeMethod(std::string_view authorization, std::string_view method) const;

  std::size_t size() const { return entries_.size(); }

 private:
  std::vector<std::pair<std::string, Role>> entries_;
};

/// "planner" or "admin".
const char* RoleName(Role role);

}  // namespace strata::server
