// strata::common::Expected, the one value-or-error template behind the planner's Expected and
// Status, the server's Result and ServiceStatus, and the client's Expected.
#include "strata/common/expected.hpp"

#include <memory>
#include <string>

#include <gtest/gtest.h>

namespace strata::common {
namespace {

struct TestError {
  std::string message;
};

TEST(Expected, HoldsAValueOrAnError) {
  Expected<int, TestError> good = 42;
  ASSERT_TRUE(good.ok());
  EXPECT_TRUE(static_cast<bool>(good));
  EXPECT_EQ(*good, 42);
  EXPECT_EQ(good.value(), 42);
  Expected<int, TestError> bad = TestError{"no"};
  ASSERT_FALSE(bad.ok());
  EXPECT_FALSE(static_cast<bool>(bad));
  EXPECT_EQ(bad.error().message, "no");
}

TEST(Expected, MovesOutValuesAndErrors) {
  Expected<std::unique_ptr<int>, TestError> good = std::make_unique<int>(7);
  std::unique_ptr<int> value = std::move(good).value();
  ASSERT_NE(value, nullptr);
  EXPECT_EQ(*value, 7);
  Expected<std::unique_ptr<int>, TestError> bad = TestError{std::string(64, 'x')};
  const TestError error = std::move(bad).error();
  EXPECT_EQ(error.message.size(), 64u);
}

TEST(Expected, VoidIsASuccessOrAnError) {
  const Expected<void, TestError> ok;
  EXPECT_TRUE(ok.ok());
  EXPECT_TRUE((Expected<void, TestError>::Ok().ok()));
  const Expected<void, TestError> failed = TestError{"broken"};
  ASSERT_FALSE(failed.ok());
  EXPECT_FALSE(static_cast<bool>(failed));
  EXPECT_EQ(failed.error().message, "broken");
}

}  // namespace
}  // namespace strata::common
