#pragma once
// Message helpers shared by the planner's validation and error paths; not installed.

#include <cstdio>
#include <string>
#include <string_view>

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
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return Error{ErrorCode::kInvalidConfig,
               field + " = " + buf + " is out of range: must be " + range, field};
}

/// "(x, y, z)" with centimetre precision, for messages in metres.
inline std::string FormatPoint(const Eigen::Vector3d& p) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
  return buf;
}

}  // namespace strata::internal
