#include "rpc/auth.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace strata::server {
namespace {

constexpr std::size_t kMinTokenLength = 16;
constexpr std::size_t kMaxTokenLength = 256;

bool TokenCharactersOk(std::string_view token) {
  for (const char c : token) {
    if (c <= ' ' || c > '~') return false;
  }
  return true;
}

// Equal in content, in time independent of where they first differ.
bool ConstantTimeEqual(std::string_view a, std::string_view b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? a[i] : 0;
    const unsigned char y = i < b.size() ? b[i] : 0;
    diff |= x ^ y;
  }
  return diff == 0;
}

}  // namespace

const char* RoleName(Role role) { return role == Role::kAdmin ? "admin" : "planner"; }

Result<TokenTable> TokenTable::Load(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) {
    return MakeError(ErrorCode::kInvalidInput, "cannot read the token file " + path.string());
  }
  std::vector<std::pair<std::string, Role>> entries;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    std::istringstream words(line);
    std::string token, role, extra;
    words >> token;
    if (token.empty() || token[0] == '#') continue;
    words >> role >> extra;
    const std::string where = fmt::format("{} line {}", path.string(), number);
    if (role.empty() || !extra.empty()) {
      return MakeError(ErrorCode::kInvalidInput, where + ": expected `TOKEN ROLE`");
    }
    if (token.size() < kMinTokenLength || token.size() > kMaxTokenLength ||
        !TokenCharactersOk(token)) {
      return MakeError(ErrorCode::kInvalidInput,
                       where + ": a token is 16 to 256 printable characters without spaces");
    }
    if (role != "planner" && role != "admin") {
      return MakeError(
          ErrorCode::kInvalidInput,
          where + ": the role must be planner or admin, not '" + role.substr(0, 32) + "'");
    }
    for (const auto& [known, unused] : entries) {
      if (known == token) {
        return MakeError(ErrorCode::kInvalidInput, where + ": this token is listed twice");
      }
    }
    entries.emplace_back(std::move(token), role == "admin" ? Role::kAdmin : Role::kPlanner);
  }
  if (entries.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "the token file " + path.string() + " holds no `TOKEN ROLE` line");
  }
  return TokenTable(std::move(entries));
}

ServiceStatus TokenTable::Authorize(std::string_view authorization, Role needed) const {
  constexpr std::string_view kScheme = "Bearer ";
  if (authorization.empty()) {
    return MakeError(ServiceErrorCode::kUnauthenticated,
                     "this server needs a token: send the metadata `authorization: Bearer "
                     "TOKEN` (strata --token, or STRATA_TOKEN)");
  }
  if (authorization.substr(0, kScheme.size()) != kScheme) {
    return MakeError(ServiceErrorCode::kUnauthenticated,
                     "the authorization metadata must be `Bearer TOKEN`");
  }
  const std::string_view token = authorization.substr(kScheme.size());
  const std::pair<std::string, Role>* match = nullptr;
  for (const auto& entry : entries_) {
    if (ConstantTimeEqual(entry.first, token)) match = &entry;
  }
  if (match == nullptr) {
    return MakeError(ServiceErrorCode::kUnauthenticated,
                     "the token is not one this server accepts (--auth-tokens)");
  }
  if (needed == Role::kAdmin && match->second != Role::kAdmin) {
    return MakeError(ServiceErrorCode::kPermissionDenied,
                     "this call changes maps and needs a token of role admin; this token's role "
                     "is planner");
  }
  return OkStatus();
}

std::optional<Role> RoleOf(std::string_view method) {
  for (const MethodRole& entry : kMethodRoles) {
    if (entry.method == method) return entry.role;
  }
  return std::nullopt;
}

ServiceStatus TokenTable::AuthorizeMethod(std::string_view authorization,
                                          std::string_view method) const {
  const std::optional<Role> role = RoleOf(method);
  if (!role) {
    return MakeError(ServiceErrorCode::kPermissionDenied,
                     "no role may call " + std::string(method) +
                         ": it is missing from the server's role table (a bug; please report it)");
  }
  return Authorize(authorization, *role);
}

}  // namespace strata::server
