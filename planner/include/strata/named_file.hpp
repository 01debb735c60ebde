#pragma once
/// A file to read, and what to call it.

#include <string>
#include <utility>

namespace strata {

/// `path` is what is opened; `name` is what messages call the file and, where a reader picks
/// the format by extension, what picks it. A plain path names itself. A server that opened and
/// checked a client's file once reads it through "/proc/self/fd/N" (the same open file, never
/// the client's path again) and names it as the client did.
struct NamedFile {
  NamedFile(std::string path_) : path(std::move(path_)), name(path) {}  // A path names itself.
  NamedFile(const char* path_) : NamedFile(std::string(path_)) {}
  NamedFile(std::string path_, std::string name_)
      : path(std::move(path_)), name(std::move(name_)) {}

  std::string path;
  std::string name;
};

}  // namespace strata
