#pragma once
// `strata-offline plan`: plans one trajectory on a map and prints it for people or as JSON,
// and can draw it as an SVG.

#include <string>
#include <vector>

namespace strata::offline {

/// Runs the command on its arguments (after "plan"); returns the process exit code:
/// 0 success, 1 the map could not be assessed or the plan failed, 2 bad arguments.
int RunPlan(const std::vector<std::string>& args);

}  // namespace strata::offline
