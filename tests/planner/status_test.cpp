#include "strata/status.hpp"

#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/terrain_config.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

TEST(Status, CodeNamesAreDistinctUpperSnakeCase) {
  std::set<std::string> names;
  for (const ErrorCode code :
       {ErrorCode::kInvalidInput, ErrorCode::kInvalidConfig, ErrorCode::kMapLoadFailed,
        ErrorCode::kResourceExhausted, ErrorCode::kStartOffGround, ErrorCode::kGoalOffGround,
        ErrorCode::kGoalUnreachable, ErrorCode::kNoPath, ErrorCode::kDeadlineExceeded,
        ErrorCode::kCancelled, ErrorCode::kSearchBudgetExhausted, ErrorCode::kProfileMismatch,
        ErrorCode::kOptimizationFailed}) {
    const std::string name = ErrorCodeName(code);
    EXPECT_TRUE(names.insert(name).second) << name;
    EXPECT_EQ(name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ_"), std::string::npos) << name;
  }
}

TEST(AssessmentConfig, DefaultsAreValid) { EXPECT_TRUE(AssessmentConfig{}.Validate().ok()); }

TEST(AssessmentConfig, ValidateNamesTheBadField) {
  const auto expect_bad = [](const AssessmentConfig& config, const std::string& field) {
    const Status s = config.Validate();
    ASSERT_FALSE(s.ok()) << field;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidConfig);
    EXPECT_THAT(s.error().message, HasSubstr(field));
  };
  AssessmentConfig c;
  c.ground.radius_m = -1;
  expect_bad(c, "ground.radius_m");
  c = {};
  c.ground.max_tilt_rad = 2.0;
  expect_bad(c, "ground.max_tilt_rad");
  c = {};
  c.grid.resolution_m = std::nan("");
  expect_bad(c, "grid.resolution_m");
  c = {};
  c.grid.max_cells = 0;
  expect_bad(c, "grid.max_cells");
  c = {};
  c.field.plane_ransac_iterations = 0;
  expect_bad(c, "field.plane_ransac_iterations");
  c = {};
  c.field.diffusion_distance_m = -0.1;
  expect_bad(c, "field.diffusion_distance_m");
  c = {};
  c.num_threads = -3;
  expect_bad(c, "num_threads");
}

}  // namespace
}  // namespace strata
