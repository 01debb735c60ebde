#pragma once
// What every strata command gets: the server, the call deadline, the output mode, streams;
// and how it fails.
#include <iostream>
#include <stdexcept>
#include <string>

namespace strata::cli {

/// Exit codes of the strata CLI.
inline constexpr int kExitOk = 0;
inline constexpr int kExitRpcError = 1;  ///< The server answered with an error (or none).
inline constexpr int kExitUsage = 2;     ///< Bad arguments or an unusable input file.

/// Bad input that CLI11 cannot see while parsing (an unreadable or malformed file, a missing
/// combination of flags): main prints it with a hint and exits with kExitUsage.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Context {
  std::string server = "127.0.0.1:50051";  ///< --server, or $STRATA_SERVER.
  double deadline_s = 30;                  ///< --deadline [s], > 0: every call has one.
  std::string token;                       ///< --token, or $STRATA_TOKEN: sent with every call.
  std::string tls_ca;  ///< --tls-ca FILE, or $STRATA_TLS_CA: TLS trusting this PEM file.
  bool json = false;   ///< --json: machine-readable output.
  std::ostream* out = &std::cout;
  std::ostream* err = &std::cerr;
};

}  // namespace strata::cli
