#pragma once
/// Error reporting of the client library: it never throws across its API and never prints.
/// A fallible call returns `Expected<T>`, a value or a `ClientError` whose message names the
/// offending field and value (e.g. "pieces[2].duration_s is -0.5 s; it must be > 0 and
/// finite").
#include <string>
#include <utility>
#include <variant>

namespace strata::client {

/// Why a call failed: one message that names the field, the value and the rule it breaks.
struct ClientError {
  std::string message;
};

/// Either a value or a ClientError.
template <typename T>
class Expected {
 public:
  Expected(T value) : storage_(std::move(value)) {}            // NOLINT: implicit by design.
  Expected(ClientError error) : storage_(std::move(error)) {}  // NOLINT: implicit by design.

  bool ok() const { return std::holds_alternative<T>(storage_); }
  explicit operator bool() const { return ok(); }

  /// The value; precondition: ok().
  T& value() & { return std::get<T>(storage_); }
  const T& value() const& { return std::get<T>(storage_); }
  T&& value() && { return std::get<T>(std::move(storage_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  /// The error; precondition: !ok().
  const ClientError& error() const { return std::get<ClientError>(storage_); }

 private:
  std::variant<T, ClientError> storage_;
};

}  // namespace strata::client
