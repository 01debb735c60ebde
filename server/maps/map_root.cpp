#include "maps/map_root.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
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

ServiceError Outside(const std::string& shown, const std::string& field) {
  return MakeError(ServiceErrorCode::kPathOutsideMapRoot,
                   "map file " + shown +
                       " is outside the server's map root (after resolving '..' and symbolic "
                       "links): give a path inside the map root")
      .Blame(field);
}

ServiceError TooLong(const std::string& shown, const std::string& field) {
  return MakeError(ErrorCode::kInvalidInput,
                   "map file " + shown +
                       " is too long: a file name holds at most 255 bytes and a path 4096")
      .Blame(field);
}

ServiceError Missing(const std::string& shown, const std::string& field) {
  return MakeError(
             ErrorCode::kMapLoadFailed,
             "map file " + shown + " does not exist under the map root or is not a regular file")
      .Blame(field);
}

}  // namespace

OpenedMapFile::OpenedMapFile(int fd, fs::path real_path)
    : fd_(fd), real_path_(std::move(real_path)) {}

OpenedMapFile::~OpenedMapFile() {
  if (fd_ >= 0) close(fd_);
}

std::string OpenedMapFile::ProcPath() const { return "/proc/self/fd/" + std::to_string(fd_); }

Result<std::shared_ptr<const OpenedMapFile>> OpenMapFile(const fs::path& root,
                                                         std::string_view requested,
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
  // First the path as text: one that leaves the root is refused before anything outside is
  // touched, so the refusal tells nothing about what is there.
  std::error_code ec;
  const fs::path normal = fs::weakly_canonical(candidate, ec);
  if (ec == std::errc::filename_too_long) return TooLong(shown, field);
  if (ec) {
    return MakeError(ErrorCode::kMapLoadFailed, "map file " + shown +
                                                    " cannot be resolved under the map root (" +
                                                    ec.message() + ")")
        .Blame(field);
  }
  if (!IsInside(normal, root)) return Outside(shown, field);
  // Then the file itself. O_NONBLOCK: opening a FIFO must not wait for a writer (it is
  // refused below as not a regular file).
  const int fd = open(candidate.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) {
    const int error = errno;
    if (error == ENAMETOOLONG) return TooLong(shown, field);
    if (error == ENOENT || error == ENOTDIR) return Missing(shown, field);
    return MakeError(ErrorCode::kMapLoadFailed, "map file " + shown +
                                                    " cannot be opened under the map root (" +
                                                    std::system_category().message(error) + ")")
        .Blame(field);
  }
  // Where the open file really is, every link resolved by the kernel as it opened it.
  const fs::path real = fs::read_symlink("/proc/self/fd/" + std::to_string(fd), ec);
  struct stat status {};
  const bool regular = fstat(fd, &status) == 0 && S_ISREG(status.st_mode);
  if (ec || !IsInside(real, root)) {
    close(fd);
    return Outside(shown, field);
  }
  if (!regular) {
    close(fd);
    return Missing(shown, field);
  }
  // Regular files ignore O_NONBLOCK; it is cleared all the same for the readers to come.
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return std::make_shared<const OpenedMapFile>(fd, real);
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
