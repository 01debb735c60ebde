#pragma once
/// The return type of every fallible call in Strata: a value or an error. The planner
/// (strata::Expected<T>, error strata::Error), the server (Result<T>, error ServiceError) and
/// the client (strata::client::Expected<T>, error ClientError) are aliases of this one
/// template. Header-only and free of dependencies, so the robot-side client uses it without
/// linking the planner library.
///
/// A value or an error converts implicitly, so a function returns either as it is. Reading
/// the alternative that is not held is a precondition violation (std::get throws
/// std::bad_variant_access).
#include <optional>
#include <type_traits>
#include <utility>
#include <variant>

namespace strata::common {

/// Either a value of type T or an error of type E (T and E distinct).
template <typename T, typename E>
class Expected {
  static_assert(!std::is_same_v<T, E>, "the value and the error need distinct types");

 public:
  Expected(T value) : storage_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Expected(E error) : storage_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

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
  const E& error() const& { return std::get<E>(storage_); }
  E&& error() && { return std::get<E>(std::move(storage_)); }

 private:
  std::variant<T, E> storage_;
};

/// Success or an error, for calls without a value. Default-constructed, it is a success.
template <typename E>
class Expected<void, E> {
 public:
  Expected() = default;
  Expected(E error) : error_(std::move(error)) {}  // NOLINT(google-explicit-constructor)
  static Expected Ok() { return {}; }

  bool ok() const { return !error_.has_value(); }
  explicit operator bool() const { return ok(); }

  /// The error; precondition: !ok().
  const E& error() const& { return error_.value(); }
  E&& error() && { return std::move(error_).value(); }

 private:
  std::optional<E> error_;
};

}  // namespace strata::common
