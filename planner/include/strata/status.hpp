#pragma once
/// Error reporting for the planner library: it never throws across its API and never prints.
/// A fallible call returns `Expected<T>` (a value or an `Error`) or `Status` (ok or an `Error`).

#include <string>
#include <utility>
#include <variant>

namespace strata {

/// Why a call failed. The server maps each code to one gRPC status in a single table.
enum class ErrorCode {
  kInvalidInput,           ///< An argument is malformed (NaN, out of range, wrong shape).
  kInvalidConfig,          ///< A configuration field is out of its documented range.
  kMapLoadFailed,          ///< A map file cannot be read or is not a well-formed point cloud.
  kResourceExhausted,      ///< The request would exceed a size or memory limit.
  kStartOffGround,         ///< No traversable ground within tolerance of the start.
  kGoalOffGround,          ///< No traversable ground within tolerance of the goal.
  kGoalUnreachable,        ///< Start and goal lie in different connected components.
  kNoPath,                 ///< The search found no path (defensive; components agreed).
  kDeadlineExceeded,       ///< The time budget or the caller's deadline ran out.
  kCancelled,              ///< The caller cancelled the request (should_stop returned true).
  kSearchBudgetExhausted,  ///< The search used its expansion budget without reaching the goal.
  kProfileMismatch,        ///< The robot profile needs terrain assessed with other parameters.
  kOptimizationFailed,  ///< The optimised trajectory failed verification (first violation named).
};

/// Stable UPPER_SNAKE_CASE name of a code, e.g. "MAP_LOAD_FAILED".
const char* ErrorCodeName(ErrorCode code);

/// A failure: a code and a message that names the offending values and says what to fix.
struct Error {
  ErrorCode code;
  std::string message;
};

/// Either a value or an Error.
template <typename T>
class Expected {
 public:
  Expected(T value) : storage_(std::move(value)) {}      // NOLINT: implicit by design.
  Expected(Error error) : storage_(std::move(error)) {}  // NOLINT: implicit by design.

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
  const Error& error() const { return std::get<Error>(storage_); }

 private:
  std::variant<T, Error> storage_;
};

/// Success or an Error, for calls with no result value.
class Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT: implicit by design.
  static Status Ok() { return Status(); }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  /// The error; precondition: !ok().
  const Error& error() const { return error_; }

 private:
  Error error_{ErrorCode::kInvalidInput, {}};
  bool ok_ = true;
};

}  // namespace strata
