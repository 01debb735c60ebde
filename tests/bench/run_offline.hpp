#pragma once
// Runs the strata-offline binary under test (STRATA_OFFLINE_BIN) through the shell, as a user
// would, and collects its exit code and output.
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace strata::testing {

struct OfflineOutcome {
  int exit_code = -1;  ///< The exit status, or -1 when it did not exit normally.
  std::string output;  ///< stdout, and stderr when asked for.
};

/// Runs `strata-offline ARGS`; stderr is merged into the output or dropped.
inline OfflineOutcome RunOffline(const std::string& args, bool with_stderr) {
  const std::string command = std::string("'") + STRATA_OFFLINE_BIN + "' " + args +
                              (with_stderr ? " 2>&1" : " 2>/dev/null");
  OfflineOutcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0;) {
    outcome.output.append(buffer, n);
  }
  const int status = pclose(pipe);
  if (WIFEXITED(status)) outcome.exit_code = WEXITSTATUS(status);
  return outcome;
}

}  // namespace strata::testing
