// The CLI's argument parsing: flags anywhere, both spellings, typed values, and the
// messages for bad ones.
#include "arguments.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::cli {
namespace {

using ::testing::HasSubstr;

Arguments Parse(std::vector<const char*> argv) {
  argv.insert(argv.begin(), "strata");
  return Arguments(static_cast<int>(argv.size()), argv.data(), {"json", "wait"});
}

std::string UsageMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const UsageError& error) {
    return error.what();
  }
  return "(no error)";
}

TEST(ArgumentsTest, FlagsGoAnywhereInEitherSpelling) {
  Arguments args =
      Parse({"--json", "plan", "--map=demo", "--start", "-1.5,2,0.3", "extra", "--wait"});
  EXPECT_EQ(args.NextPositional(), "plan");
  EXPECT_EQ(args.Take("map"), "demo");
  const auto start = args.TakeVector3("start");
  ASSERT_TRUE(start.has_value());
  EXPECT_EQ((*start)[0], -1.5);
  EXPECT_EQ((*start)[2], 0.3);
  EXPECT_TRUE(args.TakeBool("json"));
  EXPECT_TRUE(args.TakeBool("wait"));
  EXPECT_FALSE(args.TakeBool("json"));  // Taken once.
  EXPECT_THAT(UsageMessage([&] { args.Finish(); }), HasSubstr("unexpected argument \"extra\""));
  EXPECT_EQ(args.NextPositional(), "extra");
  EXPECT_NO_THROW(args.Finish());
}

TEST(ArgumentsTest, BadValuesAreNamed) {
  Arguments args = Parse({"--start", "1,2", "--goal", "1,x,3", "--dt", "abc", "--steps", "0",
                          "--t0", "inf", "--unknown", "1"});
  EXPECT_THAT(UsageMessage([&] { args.TakeVector3("start"); }), HasSubstr("--start must be x,y,z"));
  EXPECT_THAT(UsageMessage([&] { args.TakeVector3("goal"); }),
              HasSubstr("--goal component y must be a finite number, got \"x\""));
  EXPECT_THAT(UsageMessage([&] { args.TakeDouble("dt"); }),
              HasSubstr("--dt must be a finite number"));
  EXPECT_THAT(UsageMessage([&] { args.TakeInteger("steps", 1, 10); }),
              HasSubstr("--steps must be an integer in [1, 10], got \"0\""));
  EXPECT_THAT(UsageMessage([&] { args.TakeDouble("t0"); }), HasSubstr("--t0 must be a finite"));
  EXPECT_THAT(UsageMessage([&] { args.Finish(); }),
              HasSubstr("unknown or misplaced flag --unknown"));
  EXPECT_THAT(UsageMessage([] { Parse({"plan", "--map"}); }), HasSubstr("--map needs a value"));
}

}  // namespace
}  // namespace strata::cli
