#pragma once
// Runs a shell command line, as a user would type it, and collects its exit code and output.
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace strata::testing {

struct CommandOutcome {
  int exit_code = -1;  ///< The exit status, or -1 when it did not exit normally.
  std::string output;  ///< What the command wrote to stdout (redirect stderr to see it too).
};

inline CommandOutcome RunCommand(const std::string& command) {
  CommandOutcome outcome;
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
