// One tiny run of every benchmark binary of bench/ (strata-bench has bench_smoke_test), so
// that none rots between the runs that fill docs/benchmarks.md: each must exit 0 and print its
// table. The figures themselves are not checked here; they are the benchmarks' job. Runs that
// need the shared maps skip without them.
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/planner.hpp"
#include "test_util/run_command.hpp"
#include "test_util/time_scale.hpp"
#ifdef STRATA_SERVER_BENCHMARK  // Built with the server only.
#include "etcd_process.hpp"
#include "server_process.hpp"
#endif

namespace strata {
namespace {

using ::testing::HasSubstr;

bool HaveSharedMaps() {
  return std::filesystem::exists(std::string(STRATA_SHARED_MAPS_DIR) + "/spiral0.3_2.pcd") &&
         std::filesystem::exists(std::string(STRATA_SHARED_MAPS_DIR) + "/scene20.2.pcd");
}

// Runs `binary` with the arguments of `args` (as a shell splits them) and the shared maps'
// directory in STRATA_MAPS_DIR; expects exit 0 and `expected` in the output.
void ExpectRuns(const std::string& binary, const std::string& args, const std::string& expected) {
  std::vector<std::string> argv = test_util::ShellWords(args);
  argv.insert(argv.begin(), binary);
  const test_util::CommandResult run =
      test_util::RunCommand(argv, {std::string("STRATA_MAPS_DIR=") + STRATA_SHARED_MAPS_DIR});
  EXPECT_EQ(run.exit_code, 0) << binary << " " << args << "\n" << run.out << run.err;
  EXPECT_THAT(run.out, HasSubstr(expected)) << run.err;
}

TEST(AssessmentBenchmark, SmokeRun) {
  ExpectRuns(STRATA_ASSESSMENT_BENCHMARK,
             "--benchmark_filter=Assess/two_level_ramp --benchmark_repetitions=1 "
             "--benchmark_min_time=0",
             "Assess/two_level_ramp/0.1");
}

TEST(PlanningBenchmark, SmokeRun) {
  if (!HaveSharedMaps()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  // The hardest reference query plans within the product's budget in a plain build; a
  // sanitised one, beside other tests, may need its time scale more.
  const double budget_s = PlanOptions().time_budget_s * test_util::kTimeScale;
  ExpectRuns(STRATA_PLANNING_BENCHMARK, "1 1 " + std::to_string(budget_s) + " 1",
             "| sp_cross_wall | ok |");
}

TEST(TravelCostBenchmark, SmokeRun) {
  if (!HaveSharedMaps()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  ExpectRuns(STRATA_TRAVEL_COST_BENCHMARK, "--size 2 --runs 1 --pairs 2 --maps scene20.2", "|");
}

TEST(FleetBenchmark, SmokeRun) {
  ExpectRuns(STRATA_FLEET_BENCHMARK, "--minutes 0.25 --robots 3 --sites parking_garage --retries 1",
             "| parking_garage | 3 | yes |");
}

TEST(SiteBenchmark, SmokeRun) { ExpectRuns(STRATA_SITE_BENCHMARK, "40 --plans", "|"); }

TEST(EditBenchmark, SmokeRun) {
  if (!HaveSharedMaps()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  ExpectRuns(STRATA_EDIT_BENCHMARK, "--runs 1 --no-site --spiral-resolution 0.4", "|");
}

#ifdef STRATA_SERVER_BENCHMARK
TEST(StoreBenchmark, SmokeRun) {
  ExpectRuns(STRATA_STORE_BENCHMARK, "scene:two_level_ramp --runs 1 --churn-maps 2",
             "churn: 2 maps");
}

TEST(ServerBenchmark, SmokeRun) {
  if (!HaveSharedMaps()) GTEST_SKIP() << "shared maps not found in " << STRATA_SHARED_MAPS_DIR;
  // The two maps server_benchmark's header names, as it names them.
  auto server = server::testing::ServerProcess::Start(
      {"--map-root", STRATA_SHARED_MAPS_DIR, "--preload", "spiral=spiral0.3_2.pcd,resolution_m=0.2",
       "--preload", "s20=scene20.2.pcd,resolution_m=0.2"});
  ASSERT_NE(server, nullptr);
  ExpectRuns(STRATA_SERVER_BENCHMARK,
             "--server " + server->address() + " --seconds 0.2 --runs 1 --clients 1", "|");
}

TEST(SharedScheduleBenchmark, SmokeRun) {
  auto etcd = server::testing::EtcdProcess::Start();
  ASSERT_NE(etcd, nullptr) << "a real etcd is needed (scripts/install-deps.sh installs it)";
  ExpectRuns(STRATA_SHARED_SCHEDULE_BENCHMARK,
             "--etcd " + etcd->endpoint() + " --commits 5 --robots 4 --seconds 1", "| 4 | 2 |");
}
#endif

}  // namespace
}  // namespace strata
