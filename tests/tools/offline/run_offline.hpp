#pragma once
// Runs the strata-offline binary under test (STRATA_OFFLINE_BIN) as a user would, with its
// arguments written as on a shell's command line, and collects its exit code and output.
#include <string>

#include "test_util/run_command.hpp"

namespace strata::testing {

struct OfflineOutcome {
  int exit_code = -1;  ///< The exit status, or -1 when it did not exit normally.
  std::string output;  ///< stdout, followed by stderr when asked for.
};

/// Runs `strata-offline ARGS`; stderr is appended to the output or dropped.
inline OfflineOutcome RunOffline(const std::string& args, bool with_stderr) {
  std::vector<std::string> argv = test_util::ShellWords(args);
  argv.insert(argv.begin(), STRATA_OFFLINE_BIN);
  const test_util::CommandResult run = test_util::RunCommand(argv);
  return {run.exit_code, with_stderr ? run.out + run.err : run.out};
}

}  // namespace strata::testing
