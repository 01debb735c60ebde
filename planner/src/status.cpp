#include "strata/status.hpp"

#include <cstdio>

namespace strata {

const char* ErrorCodeName(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput: return "INVALID_INPUT";
    case ErrorCode::kInvalidConfig: return "INVALID_CONFIG";
    case ErrorCode::kMapLoadFailed: return "MAP_LOAD_FAILED";
    case ErrorCode::kResourceExhausted: return "RESOURCE_EXHAUSTED";
    case ErrorCode::kStartOffGround: return "START_OFF_GROUND";
    case ErrorCode::kGoalOffGround: return "GOAL_OFF_GROUND";
    case ErrorCode::kStartInKeepOut: return "START_IN_KEEP_OUT";
    case ErrorCode::kGoalInKeepOut: return "GOAL_IN_KEEP_OUT";
    case ErrorCode::kGoalUnreachable: return "GOAL_UNREACHABLE";
    case ErrorCode::kNoPath: return "NO_PATH";
    case ErrorCode::kDeadlineExceeded: return "DEADLINE_EXCEEDED";
    case ErrorCode::kCancelled: return "CANCELLED";
    case ErrorCode::kSearchBudgetExhausted: return "SEARCH_BUDGET_EXHAUSTED";
    case ErrorCode::kProfileMismatch: return "PROFILE_MISMATCH";
    case ErrorCode::kOptimizationFailed: return "OPTIMIZATION_FAILED";
    case ErrorCode::kReservationConflict: return "RESERVATION_CONFLICT";
  }
  return "UNKNOWN";
}

std::optional<ErrorCode> ErrorCodeFromName(std::string_view name) {
  for (const ErrorCode code : kAllErrorCodes) {
    if (name == ErrorCodeName(code)) return code;
  }
  return std::nullopt;
}

std::string DetailNumber(double value) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", value);
  return buf;
}

}  // namespace strata
