// Map metrics read from the registry at scrape time (no server needed).
#include "rpc/metrics.hpp"

#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "large_floor.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

TEST(MetricsTest, AMapBeingCreatedShowsItsProgressUntilItIsGone) {
  RegistryOptions options;
  options.assessment_threads = 1;
  MapRegistry registry(options);
  Metrics metrics;
  metrics.WatchMaps(&registry);
  ASSERT_TRUE(registry.Create("big", testing::LargeFloorSource(), AssessmentConfig{}).ok());
  // Scrape until the assessment is in its ground filter: the series names the map and step.
  const std::string series = "strata_map_creation_progress{map_id=\"big\",step=\"ground_filter\"}";
  std::string scrape;
  while (scrape.find(series) == std::string::npos) {
    ASSERT_EQ(registry.Get("big")->state, MapState::kCreating) << "assessed before it was seen";
    scrape = metrics.Serialize();
    std::this_thread::yield();
  }
  EXPECT_THAT(scrape, HasSubstr("strata_maps{state=\"creating\"} 1"));
  // Gone with the map.
  ASSERT_TRUE(registry.Delete("big").ok());
  EXPECT_THAT(metrics.Serialize(), Not(HasSubstr("map_id=\"big\"")));
}

}  // namespace
}  // namespace strata::server
