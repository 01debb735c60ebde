#pragma once
// What every strata command gets: the server, the call deadline, the output mode, streams.
#include <iostream>
#include <string>

namespace strata::cli {

/// Exit codes of the strata CLI.
inline constexpr int kExitOk = 0;
inline constexpr int kExitRpcError = 1;  ///< The server answered with an error (or none).
inline constexpr int kExitUsage = 2;     ///< Bad arguments or an unusable input file.

struct Context {
  std::string server = "127.0.0.1:50051";  ///< --server, or $STRATA_SERVER.
  double deadline_s = 30;                  ///< --deadline [s], > 0: every call has one.
  bool json = false;                       ///< --json: machine-readable output.
  std::ostream* out = &std::cout;
  std::ostream* err = &std::cerr;
};

}  // namespace strata::cli
