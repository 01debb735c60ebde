#pragma once
// `strata-offline assess`: terrain assessment of one map, printed for people or as JSON.

#include <string>
#include <vector>

namespace strata::offline {

/// Runs the command on its arguments (after "assess"); returns the process exit code:
/// 0 success, 1 the map could not be assessed, 2 bad arguments.
int RunAssess(const std::vector<std::string>& args);

}  // namespace strata::offline
