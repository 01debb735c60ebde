#include "strata/status.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace strata {
namespace {

TEST(Status, CodeNamesAreDistinctUpperSnakeCase) {
  std::set<std::string> names;
  for (const ErrorCode code :
       {ErrorCode::kInvalidInput, ErrorCode::kInvalidConfig, ErrorCode::kMapLoadFailed,
        ErrorCode::kResourceExhausted, ErrorCode::kStartOffGround, ErrorCode::kGoalOffGround,
        ErrorCode::kStartInKeepOut, ErrorCode::kGoalInKeepOut, ErrorCode::kGoalUnreachable,
        ErrorCode::kNoPath, ErrorCode::kDeadlineExceeded, ErrorCode::kCancelled,
        ErrorCode::kSearchBudgetExhausted, ErrorCode::kProfileMismatch,
        ErrorCode::kOptimizationFailed}) {
    const std::string name = ErrorCodeName(code);
    EXPECT_TRUE(names.insert(name).second) << name;
    EXPECT_EQ(name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ_"), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace strata
