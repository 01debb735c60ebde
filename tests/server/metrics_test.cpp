// Map metrics read from the registry at scrape time (no server needed).
#include "rpc/metrics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "held_assessment.hpp"
#include "large_floor.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// The assessment is held in its ground filter while the metrics are scraped, so that the map is
// seen creating whatever the machine's speed.
TEST(MetricsTest, AMapBeingCreatedShowsItsProgressUntilItIsGone) {
  testing::HeldAssessment held(AssessmentStage::kGroundFilter);
  RegistryOptions options;
  options.assessment_threads = 1;
  options.build = held.Builder();
  MapRegistry registry(std::move(options));
  Metrics metrics;
  metrics.WatchMaps(&registry);
  ASSERT_TRUE(registry.Create("big", testing::LargeFloorSource(), AssessmentConfig{}).ok());
  held.WaitHeld();
  // The series names the map and its step.
  const std::string scrape = metrics.Serialize();
  EXPECT_THAT(scrape,
              HasSubstr("strata_map_creation_progress{map_id=\"big\",step=\"ground_filter\"}"));
  EXPECT_THAT(scrape, HasSubstr("strata_maps{state=\"creating\"} 1"));
  // Gone with the map.
  ASSERT_TRUE(registry.Delete("big").ok());
  EXPECT_THAT(metrics.Serialize(), Not(HasSubstr("map_id=\"big\"")));
  held.Release();
  registry.Shutdown();
}

}  // namespace
}  // namespace strata::server
