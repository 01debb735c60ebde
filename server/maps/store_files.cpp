#include "maps/store_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <random>

namespace strata::server::store_files {

namespace fs = std::filesystem;

std::string ErrnoText(int error) { return std::generic_category().message(error); }

ServiceError Unavailable(const fs::path& path, const std::string& what, int error) {
  return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                   "map store: cannot " + what + " '" + path.string() + "': " + ErrnoText(error) +
                       " (check that the store volume is mounted, writable and not full)");
}

ServiceError Unavailable(const fs::path& path, const std::string& what, const std::error_code& ec) {
  return Unavailable(path, what, ec.value());
}

std::string UniqueName(std::string_view kind) {
  static std::mutex mutex;
  static std::mt19937_64 random{std::random_device{}()};
  std::uint64_t bits = 0;
  {
    const std::lock_guard lock(mutex);
    bits = random();
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(bits));
  return std::string(kind) + "." + std::to_string(::getpid()) + "." + hex;
}

ServiceStatus Sync(const fs::path& path) {
  const Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd.valid()) return Unavailable(path, "open for fsync", errno);
  if (::fsync(fd.get()) != 0) return Unavailable(path, "fsync", errno);
  return OkStatus();
}

ServiceStatus WriteNewFile(const fs::path& path, std::string_view bytes, bool durable) {
  const Fd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (!fd.valid()) return Unavailable(path, "create", errno);
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd.get(), bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Unavailable(path, "write", errno);
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  if (durable && ::fsync(fd.get()) != 0) return Unavailable(path, "fsync", errno);
  return OkStatus();
}

Result<std::optional<std::string>> ReadFileIfExists(const fs::path& path) {
  const Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd.valid()) {
    if (errno == ENOENT || errno == ENOTDIR) return std::optional<std::string>();
    return Unavailable(path, "open", errno);
  }
  std::string bytes;
  struct stat status {};
  // Read straight into a string of the file's size; a file still growing is read to its end.
  if (::fstat(fd.get(), &status) == 0 && status.st_size > 0) {
    bytes.resize(static_cast<std::size_t>(status.st_size));
  }
  std::size_t filled = 0;
  while (true) {
    if (filled == bytes.size()) bytes.resize(std::max<std::size_t>(2 * bytes.size(), 1 << 16));
    const ssize_t n = ::read(fd.get(), bytes.data() + filled, bytes.size() - filled);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Unavailable(path, "read", errno);
    if (n == 0) break;
    filled += static_cast<std::size_t>(n);
  }
  bytes.resize(filled);
  return std::optional<std::string>(std::move(bytes));
}

ServiceStatus RenameDurably(const fs::path& from, const fs::path& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) return Unavailable(to, "rename into place", errno);
  return Sync(to.parent_path());
}

void RemoveAllInSlices(const fs::path& path, const std::function<void()>& between_slices) {
  constexpr off_t kSliceBytes = off_t{16} << 20;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
    struct stat status {};
    if (::lstat(it->path().c_str(), &status) != 0 || !S_ISREG(status.st_mode) ||
        status.st_size <= kSliceBytes) {
      continue;
    }
    const Fd fd(::open(it->path().c_str(), O_WRONLY | O_CLOEXEC | O_NOFOLLOW));
    if (!fd.valid()) continue;
    for (off_t size = status.st_size; size > 0;) {
      size = std::max<off_t>(0, size - kSliceBytes);
      if (::ftruncate(fd.get(), size) != 0) break;
      if (between_slices) between_slices();
    }
  }
  std::error_code ignored;
  fs::remove_all(path, ignored);
}

}  // namespace strata::server::store_files
