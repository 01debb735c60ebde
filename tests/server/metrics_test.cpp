// Map metrics read from the registry at scrape time (no server needed).
#include "rpc/metrics.hpp"

#include <condition_variable>
#include <mutex>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "large_floor.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// The assessment is held in its ground filter while the metrics are scraped, so that the map is
// seen creating whatever the machine's speed.
TEST(MetricsTest, AMapBeingCreatedShowsItsProgressUntilItIsGone) {
  std::mutex mutex;
  std::condition_variable changed;
  bool held = false, released = false;
  RegistryOptions options;
  options.assessment_threads = 1;
  options.build = [&](MapBuildJob job, const BuildMonitor& monitor) -> Result<BuiltMap> {
    BuildMonitor holding = monitor;
    holding.on_progress = [&, report = monitor.on_progress](AssessmentStage step, double fraction) {
      if (report) report(step, fraction);
      if (step != AssessmentStage::kGroundFilter) return;
      std::unique_lock lock(mutex);
      held = true;
      changed.notify_all();
      changed.wait(lock, [&] { return released; });
    };
    Expected<BuiltMap> built = BuildMapHere(std::move(job), holding);
    if (!built) return ServiceError::FromPlanner(built.error());
    return std::move(built).value();
  };
  MapRegistry registry(std::move(options));
  Metrics metrics;
  metrics.WatchMaps(&registry);
  ASSERT_TRUE(registry.Create("big", testing::LargeFloorSource(), AssessmentConfig{}).ok());
  {
    std::unique_lock lock(mutex);
    changed.wait(lock, [&] { return held; });
  }
  // The series names the map and its step.
  const std::string scrape = metrics.Serialize();
  EXPECT_THAT(scrape,
              HasSubstr("strata_map_creation_progress{map_id=\"big\",step=\"ground_filter\"}"));
  EXPECT_THAT(scrape, HasSubstr("strata_maps{state=\"creating\"} 1"));
  // Gone with the map.
  ASSERT_TRUE(registry.Delete("big").ok());
  EXPECT_THAT(metrics.Serialize(), Not(HasSubstr("map_id=\"big\"")));
  {
    std::lock_guard lock(mutex);
    released = true;
    changed.notify_all();
  }
  registry.Shutdown();
}

}  // namespace
}  // namespace strata::server
