#pragma once
// `strata-offline scene`: writes a built-in scene (strata/scenes/scenes.hpp) to a PCD file, for
// other tools and for the baselines.

#include <string>
#include <vector>

namespace strata::offline {

/// Runs the command on its arguments (after "scene"): NAME [--seed S] [--spacing M] --out FILE.
/// Returns the process exit code: 0 written, 1 the scene could not be generated or written,
/// 2 bad arguments.
int RunScene(const std::vector<std::string>& args);

}  // namespace strata::offline
