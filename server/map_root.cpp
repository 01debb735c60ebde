#include "map_root.hpp"

#include <algorithm>
#include <system_error>

namespace strata::server {
namespace {

namespace fs = std::filesystem;

// True when every component of `root` begins `path` (component-wise, so /maps is not a
// prefix of /maps2).
bool IsInside(const fs::path& path, const fs::path& root) {
  auto root_end = root.end();
  // A trailing separator shows up as an empty last component; ignore it.
  if (!root.empty() && std::prev(root_end)->empty()) --root_end;
  const auto [root_it, path_it] = std::mismatch(root.begin(), root_end, path.begin(), path.end());
  return root_it == root_end;
}

}  // namespace

Result<fs::path> ResolveMapPath(const fs::path& root, std::string_view requested,
                                const std::string& field) {
  if (root.empty()) {
    return MakeError(ServiceErrorCode::kPathOutsideMapRoot,
                     "this server has no map root, so maps cannot be loaded from files: start "
                     "it with --map-root DIR (or STRATA_MAP_ROOT), or upload the points with "
                     "UploadMap")
        .Blame(field);
  }
  if (requested.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "the map file path is empty: give a path relative to the map root")
        .Blame(field);
  }
  if (requested.find('\0') != std::string_view::npos) {
    return MakeError(ErrorCode::kInvalidInput, "the map file path holds a NUL character")
        .Blame(field);
  }
  // The path as the client gave it, cut: it is quoted back in messages.
  constexpr std::size_t kMaxShown = 64;
  std::string shown = "'";
  shown += BoundedText(requested, kMaxShown);
  shown += '\'';
  const fs::path candidate =
      fs::path(requested).is_absolute() ? fs::path(requested) : root / fs::path(requested);
  std::error_code ec;
  const fs::path resolved = fs::weakly_canonical(candidate, ec);
  // A path that cannot be resolved is not one outside the root: say what failed.
  if (ec == std::errc::filename_too_long) {
    return MakeError(ErrorCode::kInvalidInput,
                     "map file " + shown +
                         " is too long: a file name holds at most 255 bytes and a path 4096")
        .Blame(field);
  }
  if (ec) {
    return MakeError(ErrorCode::kMapLoadFailed, "map file " + shown +
                                                    " cannot be resolved under the map root (" +
                                                    ec.message() + ")")
        .Blame(field);
  }
  if (!IsInside(resolved, root)) {
    return MakeError(ServiceErrorCode::kPathOutsideMapRoot,
                     "map file " + shown +
                         " is outside the server's map root (after resolving '..' and "
                         "symbolic links): give a path inside the map root")
        .Blame(field);
  }
  if (!fs::is_regular_file(resolved, ec)) {
    return MakeError(
               ErrorCode::kMapLoadFailed,
               "map file " + shown + " does not exist under the map root or is not a regular file")
        .Blame(field);
  }
  return resolved;
}

Result<fs::path> CanonicalMapRoot(const fs::path& root) {
  std::error_code ec;
  const fs::path canonical = fs::canonical(root, ec);
  if (ec || !fs::is_directory(canonical, ec)) {
    return MakeError(ErrorCode::kInvalidInput,
                     "map root '" + root.string() + "' is not an existing directory");
  }
  return canonical;
}

}  // namespace strata::server
