#pragma once
// `strata-offline scene`: writes a built-in scene (strata/scenes/scenes.hpp) to a PCD file, for
// other tools and for the baselines.

#include <functional>

#include <CLI/CLI.hpp>

namespace strata::offline {

/// Adds the command to `app`: NAME [--seed S] [--size M] [--spacing M] --out FILE. When the command
/// line selects it, parsing sets *run to the command, which returns the process exit code: 0
/// written, 1 the scene could not be generated or written.
void AddSceneCommand(CLI::App& app, std::function<int()>* run);

}  // namespace strata::offline
