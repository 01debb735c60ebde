#pragma once
// The map store's files: what every writer and reader of its directories needs (durable
// writes, unique temporaries, errors naming the path). Internal to maps/.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include <unistd.h>

#include "common/service_error.hpp"

namespace strata::server::store_files {

// A file descriptor closed on scope exit.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  Fd& operator=(Fd&& other) noexcept {
    if (this != &other) {
      Close();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { Close(); }
  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }

 private:
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int fd_;
};

/// The text of errno value `error`.
std::string ErrnoText(int error);

/// kMapStoreUnavailable: "map store: cannot <what> '<path>': <reason> (check ...)".
ServiceError Unavailable(const std::filesystem::path& path, const std::string& what, int error);
ServiceError Unavailable(const std::filesystem::path& path, const std::string& what,
                         const std::error_code& ec);

/// A name no other writer (thread, process or host) picks: kind, pid and 64 random bits.
std::string UniqueName(std::string_view kind);

/// fsync of a file or a directory: what was written (or renamed into it) is durable.
ServiceStatus Sync(const std::filesystem::path& path);

/// Creates `path` (which must not exist), writes `bytes` and, with `durable`, makes them
/// durable.
ServiceStatus WriteNewFile(const std::filesystem::path& path, std::string_view bytes,
                           bool durable = true);

/// The whole file, or nothing when it does not exist.
Result<std::optional<std::string>> ReadFileIfExists(const std::filesystem::path& path);

/// Renames `from` to `to` and syncs the directory that received it.
ServiceStatus RenameDurably(const std::filesystem::path& from, const std::filesystem::path& to);

/// Removes `path` and everything under it, as std::filesystem::remove_all does (what it
/// cannot remove stays), shrinking each large file a slice at a time first. Freeing a graph's
/// hundreds of megabytes in one unlink holds the file system's journal for tens of
/// milliseconds, and every fsync meanwhile (a keep-out zone's version) waits for it; between
/// slices the journal commits, and `between_slices` (may be empty) is called.
void RemoveAllInSlices(const std::filesystem::path& path,
                       const std::function<void()>& between_slices = {});

}  // namespace strata::server::store_files
