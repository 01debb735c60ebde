#pragma once
/// Error reporting of the client library: it never throws across its API and never prints.
/// A fallible call returns `Expected<T>`, a value or a `ClientError` whose message names the
/// offending field and value (e.g. "pieces[2].duration_s is -0.5 s; it must be > 0 and
/// finite").
#include <string>

#include "strata/common/expected.hpp"

namespace strata::client {

/// Why a call failed: one message that names the field, the value and the rule it breaks.
struct ClientError {
  std::string message;
};

/// Either a value or a ClientError (strata::common::Expected, shared with planner and server).
template <typename T>
using Expected = common::Expected<T, ClientError>;

}  // namespace strata::client
