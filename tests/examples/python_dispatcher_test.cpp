// examples/python/dispatcher.py against a real strata-server: it creates its map, estimates
// the costs, assigns greedily, plans the assignments in a batch among each other's
// reservations, and checks those with its own sampling; then an urgent order has a robot that
// follows replans replanned, which the example sees on the schedule's watch. It runs with Debian's
// /usr/bin/python3 and python3-grpcio (scripts/install-test-tools.sh) on the code the build
// generated from proto/; without python3-grpcio the test skips and says so.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server_process.hpp"
#include "test_util/run_command.hpp"

namespace strata::examples::testing {
namespace {

using server::testing::ServerProcess;
using test_util::CommandResult;
using test_util::RunCommand;
using ::testing::HasSubstr;

constexpr const char* kPython = "/usr/bin/python3";

TEST(PythonDispatcher, CreatesAMapEstimatesAssignsPlansInABatchAndFollowsAReplan) {
  const CommandResult probe = RunCommand({kPython, "-c", "import grpc, google.protobuf"});
  if (probe.exit_code != 0) {
    GTEST_SKIP() << "Debian's python3-grpcio or python3-protobuf is missing (run "
                    "scripts/install-test-tools.sh): "
                 << probe.err;
  }
  const auto server = ServerProcess::Start({"--no-preload"});
  ASSERT_NE(server, nullptr);
  ASSERT_TRUE(server->WaitServing(std::chrono::seconds(60))) << server->Log();
  const CommandResult run =
      RunCommand({kPython, STRATA_PYTHON_EXAMPLE, "--server", server->address()},
                 {std::string("PYTHONPATH=") + STRATA_PYTHON_API_DIR});
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err << "\n--- server log ---\n" << server->Log();
  EXPECT_THAT(run.out, HasSubstr("map python-dispatch: MAP_STATE_ACTIVE"));
  EXPECT_THAT(run.out, HasSubstr("costs: 3 robots x 4 tasks"));
  // The task off the map is left out, with the reason the estimate gives.
  EXPECT_THAT(run.out, HasSubstr("task nowhere: GOAL_OFF_GROUND"));
  EXPECT_THAT(run.out, HasSubstr("assign r3 -> pick-deck"));  // The robot already on the deck.
  EXPECT_THAT(run.out, HasSubstr("planned 3 of 3 assignments"));
  // Planned among each other's reservations, and checked by the example's own sampling.
  EXPECT_THAT(run.out, HasSubstr("checked 3 pairs of 3 reservations every 5 ms: 0 meet"));
  EXPECT_THAT(run.out, HasSubstr("released 3 reservations"));
  // The urgent order: r3 comes down at once and has r1, which follows replans, replanned to let
  // it pass; the schedule's watch saw r1's new trajectory, and the two keep r3's 2 m.
  EXPECT_THAT(run.out, HasSubstr("1 robot(s) replanned to let it pass first"));
  EXPECT_THAT(run.out, HasSubstr("r1 replanned to let r3 pass: follows the new trajectory"));
  EXPECT_THAT(run.out, HasSubstr("checked 1 pairs of 2 reservations every 5 ms: 0 meet"));
  EXPECT_THAT(run.out, HasSubstr("released 2 reservations"));
  // The server saw the three kinds of call.
  EXPECT_THAT(server->Log(), HasSubstr("rpc=EstimateCosts"));
  EXPECT_THAT(server->Log(), HasSubstr("rpc=PlanBatch"));
}

}  // namespace
}  // namespace strata::examples::testing
