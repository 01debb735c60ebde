#pragma once
// Message helpers shared by the planner's validation and error paths; not installed.

#include <cctype>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <Eigen/Core>

#include "strata/status.hpp"

namespace strata::internal {

/// The path of field `name` of a struct whose own path is `path`: "path.name", or "name" for
/// the root (empty path).
inline std::string FieldPath(std::string_view path, std::string_view name) {
  std::string result(path);
  if (!result.empty()) result += '.';
  return result += name;
}

/// kInvalidConfig blaming `field` (a path, see Error::field): "<field> = <value> is out of
/// range: must be <range>".
inline Error OutOfRange(const std::string& field, double value, const std::string& range) {
  return Error{ErrorCode::kInvalidConfig,
               fmt::format("{} = {:g} is out of range: must be {}", field, value, range), field};
}

/// `text` in single quotes for a message, cut to its first 64 bytes ("...'" marks a cut)
/// and with unprintable bytes as '?': text from a file or a request may be of any length
/// and hold anything, and a message must stay short and printable.
inline std::string Quote(std::string_view text) {
  constexpr std::size_t kMaxQuoted = 64;
  std::string out = "'";
  for (char c : text.substr(0, kMaxQuoted)) {
    out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  return out + (text.size() > kMaxQuoted ? "...'" : "'");
}

/// "(x, y, z)" with centimetre precision, for messages in metres.
inline std::string FormatPoint(const Eigen::Vector3d& p) {
  return fmt::format("({:.2f}, {:.2f}, {:.2f})", p.x(), p.y(), p.z());
}

}  // namespace strata::internal
