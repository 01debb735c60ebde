#pragma once
// `strata-offline assess`: terrain assessment of one map, printed for people or as JSON.

#include <functional>

#include <CLI/CLI.hpp>

namespace strata::offline {

/// Adds the command to `app`. When the command line selects it, parsing sets *run to the
/// command, which returns the process exit code: 0 success, 1 the map could not be assessed.
void AddAssessCommand(CLI::App& app, std::function<int()>* run);

}  // namespace strata::offline
