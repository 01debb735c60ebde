#pragma once
// Runs a program to completion and collects its exit code, stdout and stderr.
#include <string>
#include <vector>

namespace strata::client::testing {

struct CommandResult {
  int exit_code = -1;  ///< The exit status, or -1 when it died of a signal.
  std::string out;     ///< Everything written to stdout.
  std::string err;     ///< Everything written to stderr.
};

/// Runs `argv[0]` with `argv` and the environment plus `env` ("NAME=value") entries.
CommandResult RunCommand(const std::vector<std::string>& argv,
                         const std::vector<std::string>& env = {});

}  // namespace strata::client::testing
