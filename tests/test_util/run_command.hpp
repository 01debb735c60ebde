#pragma once
// Runs a program to completion, as a user would from a shell but without one, and collects
// its exit code, stdout and stderr. The one way tests run the binaries they check.
#include <string>
#include <vector>

namespace strata::test_util {

struct CommandResult {
  int exit_code = -1;  ///< The exit status, or -1 when it died of a signal.
  std::string out;     ///< Everything written to stdout.
  std::string err;     ///< Everything written to stderr.
};

/// Runs `argv[0]` (a path) with `argv` and the environment plus `env` ("NAME=value") entries;
/// an entry of `env` wins over an inherited variable of the same name.
CommandResult RunCommand(const std::vector<std::string>& argv,
                         const std::vector<std::string>& env = {});

/// Splits `line` into words as a POSIX shell does (quotes, backslashes), through wordexp(3)
/// without command substitution, so a test can write a command line as a user types it.
/// Fails the calling test (and returns no words) when the line does not split.
std::vector<std::string> ShellWords(const std::string& line);

}  // namespace strata::test_util
