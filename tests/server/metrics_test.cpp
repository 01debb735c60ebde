// Map and reservation metrics read at scrape time (no server needed).
#include "rpc/metrics.hpp"

#include <sstream>
#include <string>

#include <chrono>
#include <future>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "held_assessment.hpp"
#include "http/metrics_page.hpp"
#include "large_floor.hpp"
#include "strata/version.hpp"

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
  EXPECT_THAT(
      scrape,
      HasSubstr("strata_map_creation_progress_ratio{map_id=\"big\",step=\"ground_filter\"}"));
  EXPECT_THAT(scrape, HasSubstr("strata_maps{state=\"creating\"} 1"));
  // Gone with the map.
  ASSERT_TRUE(registry.Delete("big").ok());
  EXPECT_THAT(metrics.Serialize(), Not(HasSubstr("map_id=\"big\"")));
  held.Release();
  registry.Shutdown();
}

constexpr ScheduleLimits kScheduleLimits{.max_reservations_per_map = 4,
                                         .default_lease_s = 60,
                                         .max_lease_s = 600,
                                         .max_horizon_s = 3600,
                                         .default_separation_m = 0.1};

// The schedule's figures, read at scrape time: live reservations, and expired leases collected.
TEST(MetricsTest, ReservationsAreCountedAndTheirExpiryToo) {
  std::int64_t now = 1'795'000'000'000'000'000;
  ReservationSchedule schedule(kScheduleLimits, [&now] { return now; });
  Metrics metrics;
  metrics.WatchReservations(&schedule);
  Reservation parked;
  parked.map_id = "site";
  parked.reserved.robot_id = "r1";
  TrajectoryPiece piece;
  piece.duration_s = 1;
  piece.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  parked.reserved.motion.trajectory.pieces.push_back(piece);
  parked.reserved.motion.start_ns = now;
  parked.reserved.motion.end_ns = AddSeconds(now, 10);
  ASSERT_TRUE(schedule.Commit(parked, SeparationRule{}, Caller{.owner = "", .admin = true}).ok());
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations 1\n"));
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations_expired_total 0\n"));
  now = AddSeconds(now, 11);
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations 0\n"));
  schedule.List("site");  // Collects it.
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations_expired_total 1\n"));
}

// A reservation replanned for another robot's plan is counted once it is committed.
TEST(MetricsTest, ReservationsReplannedForOtherPlansAreCounted) {
  const std::int64_t now = 1'795'000'000'000'000'000;
  ReservationSchedule schedule(kScheduleLimits, [&now] { return now; });
  Metrics metrics;
  metrics.WatchReservations(&schedule);
  // A robot parked at `x` from 1 s from now for 10 s.
  const auto parked_at = [&](const std::string& robot, double x) {
    Reservation parked;
    parked.map_id = "site";
    parked.reserved.robot_id = robot;
    TrajectoryPiece piece;
    piece.duration_s = 1;
    piece.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
    piece.coefficients(0, 0) = x;
    parked.reserved.motion.trajectory.pieces.push_back(piece);
    parked.reserved.motion.start_ns = AddSeconds(now, 1);
    parked.reserved.motion.end_ns = AddSeconds(now, 11);
    return parked;
  };
  const Caller anyone{.owner = "", .admin = true};
  Reservation r1 = parked_at("r1", 0);
  r1.replan_profile = BuiltinProfile("differential").value();
  const Result<Reservation> first = schedule.Commit(r1, SeparationRule{}, anyone);
  ASSERT_TRUE(first.ok());
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations_replanned_total 0\n"));
  // r2 parks where r1 was; r1, replanned, parks 5 m away.
  const Result<std::vector<Reservation>> both =
      schedule.CommitReplanning(parked_at("r2", 0), {parked_at("r1", 5).reserved},
                                first.value().revision, SeparationRule{}, anyone);
  ASSERT_TRUE(both.ok()) << both.error().message;
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_reservations_replanned_total 1\n"));
}

// The planning slots as an autoscaler reads them: busy slots and calls queued for one, while a
// call holds the only slot and another waits.
TEST(MetricsTest, QueuedPlansAndBusySlotsAreReadAtScrape) {
  PlanningSlots slots(1, 4, 10);
  Metrics metrics;
  metrics.WatchPlanningSlots(&slots);
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_plans_queued 0"));
  std::promise<void> holding, release;
  std::thread first([&] {
    (void)slots.Run(CallControl{}, [&](const std::function<bool()>&, double) {
      holding.set_value();
      release.get_future().wait();
      return OkStatus();
    });
  });
  holding.get_future().wait();
  std::thread second([&] {
    (void)slots.Run(CallControl{}, [](const std::function<bool()>&, double) { return OkStatus(); });
  });
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (slots.queued() != 1 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::yield();  // The second call is about to queue.
  }
  ASSERT_EQ(slots.queued(), 1u);
  const std::string scrape = metrics.Serialize();
  EXPECT_THAT(scrape, HasSubstr("strata_plans_queued 1"));
  EXPECT_THAT(scrape, HasSubstr("strata_planning_slots_busy 1"));
  EXPECT_THAT(scrape, HasSubstr("strata_planning_slots 1"));
  release.set_value();
  first.join();
  second.join();
  EXPECT_THAT(metrics.Serialize(), HasSubstr("strata_planning_slots_busy 0"));
}

// The process metrics Prometheus users expect, and the build's version.
TEST(MetricsTest, ProcessFiguresAndTheBuildAreExported) {
  Metrics metrics;
  const std::string scrape = metrics.Serialize();
  for (const char* name :
       {"process_cpu_seconds_total ", "process_resident_memory_bytes ", "process_open_fds ",
        "process_max_fds ", "process_start_time_seconds "}) {
    EXPECT_THAT(scrape, HasSubstr(name));
  }
  EXPECT_THAT(scrape, HasSubstr("strata_build_info{commit=\"" + std::string(kStrataCommit) +
                                "\",version=\"" + std::string(kStrataVersion) + "\"}"));
  EXPECT_THAT(scrape, Not(HasSubstr("process_resident_memory_bytes 0\n")));
}

// The metrics port answers GET /metrics with the exposition, and nothing else; the exposition
// holds only the families metrics.hpp lists (prometheus-cpp's exposer added exposer_* series,
// their latencies in microseconds).
TEST(MetricsTest, ThePageServesTheExpositionAtMetricsOnly) {
  Metrics metrics;
  const MetricsPage page(&metrics);
  const HttpResponse scrape = page.Handle({"GET", "/metrics", "", ""}, CallControl{});
  EXPECT_EQ(scrape.status, 200);
  EXPECT_EQ(scrape.content_type, "text/plain; version=0.0.4; charset=utf-8");
  EXPECT_THAT(scrape.body, HasSubstr("strata_build_info{"));
  std::istringstream lines(scrape.body);
  int families = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# TYPE ", 0) != 0) continue;
    ++families;
    const std::string name = line.substr(7, line.find(' ', 7) - 7);
    EXPECT_TRUE(name.rfind("grpc_server_", 0) == 0 || name.rfind("strata_", 0) == 0 ||
                name.rfind("process_", 0) == 0)
        << name;
  }
  EXPECT_GE(families, 7);
  EXPECT_THAT(scrape.body, HasSubstr("# TYPE process_open_fds gauge"));

  EXPECT_EQ(page.Handle({"GET", "/", "", ""}, CallControl{}).status, 404);
  EXPECT_EQ(page.Handle({"GET", "/metrics/x", "", ""}, CallControl{}).status, 404);
  const HttpResponse posted = page.Handle({"POST", "/metrics", "", "x"}, CallControl{});
  EXPECT_EQ(posted.status, 405);
  EXPECT_THAT(posted.headers,
              ::testing::Contains(std::pair<std::string, std::string>("Allow", "GET, HEAD")));
}

}  // namespace
}  // namespace strata::server
