#pragma once
// `strata-offline plan`: plans one trajectory on a map and prints it for people or as JSON,
// and can draw it as an SVG.

#include <functional>

#include <CLI/CLI.hpp>

namespace strata::offline {

/// Adds the command to `app`. When the command line selects it, parsing sets *run to the
/// command, which returns the process exit code: 0 success, 1 the map could not be assessed,
/// the plan failed or the SVG could not be written.
void AddPlanCommand(CLI::App& app, std::function<int()>* run);

}  // namespace strata::offline
