#pragma once
/// Confining map files to the server's map root.
#include <filesystem>
#include <string_view>

#include "service_error.hpp"

namespace strata::server {

/// Resolves `requested` (relative to `root`, or absolute) to the canonical path of an
/// existing regular file inside `root`. `root` must be canonical (see CanonicalMapRoot).
/// Symbolic links are followed before the check, so a link that points out of the root is
/// refused like `..`. Fails with kPathOutsideMapRoot when the path leaves the root or `root`
/// is empty (file maps disabled), kInvalidInput for an empty path or one holding a NUL, and
/// kMapLoadFailed when nothing, or not a regular file, is there. Containment is decided
/// before existence, so a refusal tells nothing about files outside the root. Errors blame
/// `field` (e.g. "file.path").
Result<std::filesystem::path> ResolveMapPath(const std::filesystem::path& root,
                                             std::string_view requested, const std::string& field);

/// The canonical form of an existing directory, for use as a map root; kInvalidInput naming
/// the path when it is missing or not a directory.
Result<std::filesystem::path> CanonicalMapRoot(const std::filesystem::path& root);

}  // namespace strata::server
