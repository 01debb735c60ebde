#pragma once
// Runs the strata-offline binary under test (STRATA_OFFLINE_BIN) through the shell, as a user
// would, and collects its exit code and output.
#include <string>

#include "test_util/run_command.hpp"

namespace strata::testing {

using OfflineOutcome = CommandOutcome;

/// Runs `strata-offline ARGS`; stderr is merged into the output or dropped.
inline OfflineOutcome RunOffline(const std::string& args, bool with_stderr) {
  return RunCommand(std::string("'") + STRATA_OFFLINE_BIN + "' " + args +
                    (with_stderr ? " 2>&1" : " 2>/dev/null"));
}

}  // namespace strata::testing
