#include "strata/status.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace strata {
namespace {

TEST(Status, CodeNamesAreDistinctUpperSnakeCase) {
  std::set<std::string> names;
  for (const ErrorCode code : kAllErrorCodes) {
    const std::string name = ErrorCodeName(code);
    EXPECT_TRUE(names.insert(name).second) << name;
    EXPECT_EQ(name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ_"), std::string::npos) << name;
  }
}

TEST(Status, EveryCodeIsListedOnceInDeclarationOrder) {
  // The enum's values are 0, 1, ... in declaration order: the list must be exactly them.
  int expected = 0;
  for (const ErrorCode code : kAllErrorCodes) EXPECT_EQ(static_cast<int>(code), expected++);
  EXPECT_EQ(expected, static_cast<int>(ErrorCode::kReservationConflict) + 1);
}

TEST(Status, NamesReadBackAsTheirCodes) {
  for (const ErrorCode code : kAllErrorCodes) {
    EXPECT_EQ(ErrorCodeFromName(ErrorCodeName(code)), code) << ErrorCodeName(code);
  }
  EXPECT_FALSE(ErrorCodeFromName("UNKNOWN").has_value());
  EXPECT_FALSE(ErrorCodeFromName("map_load_failed").has_value());
}

}  // namespace
}  // namespace strata
