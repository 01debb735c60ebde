#pragma once
// Message helpers shared by the planner's validation and error paths; not installed.

#include <cstdio>
#include <string>

#include <Eigen/Core>

#include "strata/status.hpp"

namespace strata::internal {

/// kInvalidConfig: "<field> = <value> is out of range: must be <range>".
inline Error OutOfRange(const std::string& field, double value, const std::string& range) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return Error{ErrorCode::kInvalidConfig,
               field + " = " + buf + " is out of range: must be " + range};
}

/// "(x, y, z)" with centimetre precision, for messages in metres.
inline std::string FormatPoint(const Eigen::Vector3d& p) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
  return buf;
}

}  // namespace strata::internal
