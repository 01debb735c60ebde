// The server's concurrency without gRPC: sixteen planners on two shared maps while a third map
// is created and deleted, all through the MapRegistry as the Plan RPC uses it. The TSan build
// (STRATA_TSAN, run by scripts/test.sh) runs this test; server_ops_test does the same through
// the real server, which TSan cannot instrument.
#include <atomic>
#include <chrono>
#include <future>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "maps/map_registry.hpp"
#include "strata/planner.hpp"
#include "strata/planning/robot_profile.hpp"

namespace strata::server {
namespace {

using std::chrono::steady_clock;

constexpr auto kLongWait = std::chrono::minutes(5);  // TSan slows planning 5–15×.

struct Query {
  std::string map_id;
  Eigen::Vector3d start;
  Eigen::Vector3d goal;
};

// Demo: floor to deck up the ramp. Room: across the floor between the stairs and the walls.
// The same starts as server_ops_test, shifted per client.
Query QueryFor(int client, int attempt) {
  const double shift = 0.1 * client;
  if ((client + attempt) % 2 == 0) return {"demo", {2, 2 + shift, 0.3}, {10, 10, 3.3}};
  return {"room", {1, 1 + shift, 0.3}, {6.5, 4.5, 0.3}};
}

Expected<PlanResult> PlanOn(const MapRegistry& registry, const Query& query) {
  Result<ActiveMap> map = registry.GetActive(query.map_id);
  if (!map.ok()) return Error{ErrorCode::kInvalidInput, map.error().message};
  PlanRequest request;
  request.profile = BuiltinProfile("differential").value();
  request.start.position_m = query.start;
  request.goal.position_m = query.goal;
  request.options.time_budget_s = 120;  // Correctness, not speed, is under test here.
  return Plan(*map.value().map, request);
}

bool SameTrajectory(const Trajectory& a, const Trajectory& b) {
  if (a.pieces.size() != b.pieces.size()) return false;
  for (std::size_t i = 0; i < a.pieces.size(); ++i) {
    if (a.pieces[i].duration_s != b.pieces[i].duration_s) return false;
    if (a.pieces[i].coefficients != b.pieces[i].coefficients) return false;
  }
  return true;
}

TEST(RegistryPlanningConcurrencyTest, SixteenPlannersOnTwoMapsWhileAThirdComesAndGoes) {
  RegistryOptions options;
  options.max_concurrent_assessments = 2;
  options.assessment_threads = 1;
  MapRegistry registry(options);
  ASSERT_TRUE(registry.Create("demo", SceneMapSource{"two_level_ramp", 0}, {}).ok());
  ASSERT_TRUE(registry.Create("room", SceneMapSource{"stairs_ramp_room", 0}, {}).ok());
  for (const char* id : {"demo", "room"}) {
    Result<MapSnapshot> done = registry.WaitUntilDone(id, steady_clock::now() + kLongWait, {});
    ASSERT_TRUE(done.ok());
    ASSERT_EQ(done.value().state, MapState::kActive) << id;
  }

  constexpr int kPlanners = 16;
  constexpr int kPlansPerPlanner = 2;
  std::atomic<bool> planning{true};
  auto churn = std::async(std::launch::async, [&] {
    int cycles = 0;
    while (planning || cycles < 2) {
      const std::uint32_t seed = static_cast<std::uint32_t>(cycles);
      EXPECT_TRUE(registry.Create("churn", SceneMapSource{"uneven_terrain", seed}, {}).ok());
      if (cycles % 2 == 0) {  // Delete the others while still CREATING.
        registry.WaitUntilDone("churn", steady_clock::now() + kLongWait, {});
      }
      EXPECT_TRUE(registry.Delete("churn").ok());
      registry.List("", 10);
      registry.Totals();
      ++cycles;
    }
    return cycles;
  });

  // Every planner starts at once, so the first plans on each map race to build its graph.
  std::vector<std::future<std::vector<Expected<PlanResult>>>> planners;
  for (int p = 0; p < kPlanners; ++p) {
    planners.push_back(std::async(std::launch::async, [&registry, p] {
      std::vector<Expected<PlanResult>> results;
      for (int i = 0; i < kPlansPerPlanner; ++i)
        results.push_back(PlanOn(registry, QueryFor(p, i)));
      return results;
    }));
  }
  std::vector<std::vector<Expected<PlanResult>>> results;
  for (auto& planner : planners) results.push_back(planner.get());
  planning = false;
  EXPECT_GE(churn.get(), 2);

  // Planning is deterministic, so a plan made alone afterwards must equal each concurrent one:
  // a race that corrupted a shared graph or field would show here even if TSan missed it.
  for (int p = 0; p < kPlanners; ++p) {
    for (int i = 0; i < kPlansPerPlanner; ++i) {
      const Expected<PlanResult>& concurrent = results[p][i];
      ASSERT_TRUE(concurrent.ok())
          << "planner " << p << " plan " << i << ": " << concurrent.error().message;
      const Expected<PlanResult> alone = PlanOn(registry, QueryFor(p, i));
      ASSERT_TRUE(alone.ok()) << alone.error().message;
      EXPECT_TRUE(SameTrajectory(concurrent.value().trajectory, alone.value().trajectory))
          << "planner " << p << " plan " << i << " differs from the same plan made alone";
    }
  }
  const MapTotals totals = registry.Totals();
  EXPECT_EQ(totals.active, 2);
  EXPECT_EQ(totals.creating, 0);
}

}  // namespace
}  // namespace strata::server
