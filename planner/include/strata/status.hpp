#pragma once
/// Error reporting for the planner library: it never throws across its API and never prints.
/// A fallible call returns `Expected<T>` (a value or an `Error`) or `Status` (ok or an `Error`).

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "strata/common/expected.hpp"

namespace strata {

/// Why a call failed. The server maps each code to one gRPC status in a single table.
enum class ErrorCode {
  kInvalidInput,           ///< An argument is malformed (NaN, out of range, wrong shape).
  kInvalidConfig,          ///< A configuration field is out of its documented range.
  kMapLoadFailed,          ///< A map file cannot be read or is not a well-formed point cloud.
  kResourceExhausted,      ///< The request would exceed a size or memory limit.
  kStartOffGround,         ///< No traversable ground within tolerance of the start.
  kGoalOffGround,          ///< No traversable ground within tolerance of the goal.
  kStartInKeepOut,         ///< The start puts the robot inside a keep-out zone.
  kGoalInKeepOut,          ///< The goal puts the robot inside a keep-out zone.
  kGoalUnreachable,        ///< Start, goal not connected (components, or keep-out zones).
  kNoPath,                 ///< The search found no path (defensive; components agreed).
  kDeadlineExceeded,       ///< The time budget or the caller's deadline ran out.
  kCancelled,              ///< The caller cancelled the request (should_stop returned true).
  kSearchBudgetExhausted,  ///< The search used its expansion budget without reaching the goal.
  kProfileMismatch,        ///< The robot profile needs terrain assessed with other parameters.
  kOptimizationFailed,   ///< The optimised trajectory failed verification (first violation named).
  kReservationConflict,  ///< The trajectory would meet another robot's reservation (named).
};

/// Every ErrorCode, in declaration order.
inline constexpr ErrorCode kAllErrorCodes[] = {
    ErrorCode::kInvalidInput,          ErrorCode::kInvalidConfig,
    ErrorCode::kMapLoadFailed,         ErrorCode::kResourceExhausted,
    ErrorCode::kStartOffGround,        ErrorCode::kGoalOffGround,
    ErrorCode::kStartInKeepOut,        ErrorCode::kGoalInKeepOut,
    ErrorCode::kGoalUnreachable,       ErrorCode::kNoPath,
    ErrorCode::kDeadlineExceeded,      ErrorCode::kCancelled,
    ErrorCode::kSearchBudgetExhausted, ErrorCode::kProfileMismatch,
    ErrorCode::kOptimizationFailed,    ErrorCode::kReservationConflict,
};

/// Stable UPPER_SNAKE_CASE name of a code, e.g. "MAP_LOAD_FAILED".
const char* ErrorCodeName(ErrorCode code);

/// The code whose ErrorCodeName is `name`, if any.
std::optional<ErrorCode> ErrorCodeFromName(std::string_view name);

/// A failure: a code, a message that names the offending values and says what to fix, and,
/// when one field of the input is at fault, its path.
struct Error {
  ErrorCode code;
  std::string message;
  /// Path of the field at fault in the planner's structs, e.g. "profile.max_tilt_rad",
  /// "options.optimizer.weights.safety", "start.position_m.x", "grid.resolution_m"; empty when
  /// no single field is to blame. Set where the error is made, never recovered from the
  /// message; the server maps it to the request field (server/rpc/proto_convert.hpp).
  std::string field = {};
  /// Machine-readable facts about the failure, beside the message (the server passes them on
  /// as google.rpc.ErrorInfo metadata): for kStartOffGround / kGoalOffGround the nearest
  /// traversable point, "nearest_x_m", "nearest_y_m", "nearest_z_m" (its reference point [m]),
  /// "nearest_level" and "nearest_distance_m" (SnapToSurface); for kGoalUnreachable over
  /// disconnected ground "start_component", "goal_component" (SurfaceGraph::component labels)
  /// and "start_component_nodes", "goal_component_nodes" (their sizes), or, when keep-out zones
  /// close every way, "zones_in_the_way" (their names, comma-separated). Numbers are printed
  /// with up to 6 significant digits.
  std::map<std::string, std::string> details = {};
};

/// `value` as Error::details holds numbers ("%.6g").
std::string DetailNumber(double value);

/// Either a value or an Error.
template <typename T>
using Expected = common::Expected<T, Error>;

/// Success or an Error, for calls with no result value.
using Status = common::Expected<void, Error>;

}  // namespace strata
