#pragma once
/// Confining map files to the server's map root.
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "common/service_error.hpp"

namespace strata::server {

/// A map file opened inside the map root. What was checked is what gets read: the open
/// descriptor (through ProcPath in this process, handed on to a map worker otherwise), never
/// the path again, so no link or rename after the check can put another file in its place.
class OpenedMapFile {
 public:
  /// Takes `fd` (an open, readable file), known to be at `real_path` (may be empty when not
  /// known, as in a map worker that inherited the descriptor).
  OpenedMapFile(int fd, std::filesystem::path real_path);
  ~OpenedMapFile();
  OpenedMapFile(const OpenedMapFile&) = delete;
  OpenedMapFile& operator=(const OpenedMapFile&) = delete;

  int fd() const { return fd_; }
  /// "/proc/self/fd/N": a path that opens this same file, in this process.
  std::string ProcPath() const;
  /// Where the file was when it was opened, all links resolved.
  const std::filesystem::path& real_path() const { return real_path_; }

 private:
  int fd_;
  std::filesystem::path real_path_;
};

/// Opens `requested` (relative to `root`, or absolute) read-only as an existing regular file
/// inside `root`. `root` must be canonical (see CanonicalMapRoot). The path is refused at once
/// when, read as text, it leaves the root; then the file is opened (following any links, as
/// the kernel resolves every component) and its real path, read from the open descriptor, must
/// lie inside the root too: a link that points out of the root is refused however the path
/// reaches it ("link", "./link", "missing/../link", "dir/../../root/link", a linked
/// directory). Fails with kPathOutsideMapRoot when the path or the file leaves the root or
/// `root` is empty (file maps disabled), kInvalidInput for an empty path, one holding a NUL or
/// one too long, and kMapLoadFailed when nothing, or not a regular file, is there or it cannot
/// be read. Errors blame `field` (e.g. "file.path") and quote the path as given.
Result<std::shared_ptr<const OpenedMapFile>> OpenMapFile(const std::filesystem::path& root,
                                                         std::string_view requested,
                                                         const std::string& field);

/// The canonical form of an existing directory, for use as a map root; kInvalidInput naming
/// the path when it is missing or not a directory.
Result<std::filesystem::path> CanonicalMapRoot(const std::filesystem::path& root);

}  // namespace strata::server
