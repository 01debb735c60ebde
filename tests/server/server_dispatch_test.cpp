// The dispatcher's RPCs end to end against the real strata-server binary: EstimateCosts (cost
// matrices, their agreement with Plan, their limits) and PlanBatch (a stream of results, bad
// items among good ones), with deadlines and cancellation on both.
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <thread>

#include <gmock/gmock.h>

#include "server_fixture.hpp"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;

using Clock = std::chrono::steady_clock;

class DispatchTest : public ServerFixture {
 protected:
  grpc::Status Estimate(const v1::EstimateCostsRequest& request,
                        v1::EstimateCostsResponse* response, double deadline_s = 60) {
    grpc::ClientContext context;
    SetDeadline(&context, deadline_s);
    return planner_->EstimateCosts(&context, request, response);
  }

  // The whole stream of a PlanBatch call: its results by index, and how it ended.
  struct BatchOutcome {
    std::vector<v1::PlanBatchResponse> results;
    grpc::Status status;
  };
  BatchOutcome Batch(const v1::PlanBatchRequest& request, double deadline_s = 60) {
    grpc::ClientContext context;
    SetDeadline(&context, deadline_s);
    auto reader = planner_->PlanBatch(&context, request);
    BatchOutcome outcome;
    v1::PlanBatchResponse item;
    while (reader->Read(&item)) outcome.results.push_back(item);
    outcome.status = reader->Finish();
    return outcome;
  }

  // The log's line for the `nth` finished call of `rpc` (1 = the first), waiting for it up to
  // `timeout`; empty if none came.
  std::string RpcLogLine(const std::string& rpc, std::chrono::seconds timeout, int nth = 1) {
    const std::string key = "rpc=" + rpc + " ";
    if (!server_->WaitForLog(key, timeout)) return "";
    const auto deadline = Clock::now() + timeout;
    do {
      const std::string log = server_->Log();
      std::size_t at = std::string::npos;
      for (int k = 0; k < nth; ++k) {
        at = log.find(key, at == std::string::npos ? 0 : at + 1);
        if (at == std::string::npos) break;
      }
      if (at != std::string::npos) {
        const std::size_t newline = log.rfind('\n', at);
        const std::size_t begin = newline == std::string::npos ? 0 : newline + 1;
        return log.substr(begin, log.find('\n', at) - begin);
      }
      std::this_thread::yield();
    } while (Clock::now() < deadline);
    return "";
  }

  // Waits until the server has started `count` calls of `method` (its metrics say so).
  bool WaitStarted(const std::string& method, double count) {
    const auto deadline = Clock::now() + std::chrono::seconds(30);
    while (Clock::now() < deadline) {
      if (MetricValue(HttpGet(server_->metrics_port(), "/metrics"), "grpc_server_started_total",
                      {"grpc_method=\"" + method + "\""}) >= count) {
        return true;
      }
      std::this_thread::yield();
    }
    return false;
  }
};

v1::EstimateCostsRequest CostsRequest(const std::string& map_id,
                                      const std::vector<std::array<double, 3>>& starts,
                                      const std::vector<std::array<double, 3>>& goals) {
  v1::EstimateCostsRequest request;
  request.set_map_id(map_id);
  request.set_profile_name("differential");
  for (const auto& p : starts) SetXyz(request.add_starts_m(), p[0], p[1], p[2]);
  for (const auto& p : goals) SetXyz(request.add_goals_m(), p[0], p[1], p[2]);
  return request;
}

v1::PlanRequest PlanFor(const v1::EstimateCostsRequest& costs, int i, int j) {
  v1::PlanRequest plan;
  plan.set_map_id(costs.map_id());
  if (costs.has_profile()) {
    *plan.mutable_profile() = costs.profile();
  } else {
    plan.set_profile_name(costs.profile_name());
  }
  *plan.mutable_start()->mutable_position_m() = costs.starts_m(i);
  *plan.mutable_goal()->mutable_position_m() = costs.goals_m(j);
  return plan;
}

// Floor, deck and floor-under-the-deck points of the demo hall (scenes: two_level_ramp).
const std::array<double, 3> kFloor = {2, 2, 0.3};
const std::array<double, 3> kDeck = {10, 10, 3.3};
const std::array<double, 3> kOpenFloor = {8, 5.25, 0.3};
const std::array<double, 3> kUnderDeck = {12, 9, 0.3};
const std::array<double, 3> kOffMap = {100, 100, 0};

TEST_F(DispatchTest, EstimatesEveryPairOfTheDemoAndSaysWhyNotPerEndAndCell) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  const v1::EstimateCostsRequest request =
      CostsRequest("demo", {kFloor, kDeck, kOffMap}, {kDeck, kOpenFloor, kUnderDeck});
  v1::EstimateCostsResponse response;
  const grpc::Status status = Estimate(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.starts_size(), 3);
  ASSERT_EQ(response.goals_size(), 3);
  ASSERT_EQ(response.cells_size(), 9);
  EXPECT_EQ(response.starts(0).reason(), "");
  EXPECT_EQ(response.starts(1).snapped().level(), 1u);
  EXPECT_EQ(response.starts(2).reason(), "START_OFF_GROUND");
  EXPECT_THAT(response.starts(2).message(), HasSubstr("the nearest is"));
  EXPECT_EQ(response.profile().name(), "differential");
  EXPECT_FALSE(response.map_version().empty());
  EXPECT_GT(response.stats().searches(), 0);
  EXPECT_GT(response.stats().total_s(), 0);
  for (int j = 0; j < 3; ++j) {
    EXPECT_FALSE(response.cells(6 + j).reachable());
    EXPECT_EQ(response.cells(6 + j).reason(), "START_OFF_GROUND");
  }
  // Every other pair is reachable, and Plan agrees: its trajectory is about as long, and
  // takes at least the estimate's time less what the margin and the corners leave.
  const double v_max = response.profile().max_speed_horizontal_mps();
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 3; ++j) {
      const v1::CostCell& cell = response.cells(i * 3 + j);
      if (i == 1 && j == 0) {  // Deck to the same deck point.
        EXPECT_TRUE(cell.reachable());
        EXPECT_EQ(cell.time_s(), 0);
        continue;
      }
      ASSERT_TRUE(cell.reachable()) << i << " " << j << " " << cell.reason();
      EXPECT_GE(cell.time_s(), cell.length_m() / v_max) << i << " " << j;
      v1::PlanResponse plan;
      const grpc::Status planned = Plan(PlanFor(request, i, j), &plan);
      ASSERT_TRUE(planned.ok()) << planned.error_message();
      EXPECT_NEAR(cell.length_m(), plan.stats().length_m(), 0.15 * plan.stats().length_m())
          << i << " " << j;
      EXPECT_LE(cell.time_s(), 1.1 * plan.stats().duration_s()) << i << " " << j;
    }
  }
}

TEST_F(DispatchTest, UnreachableCellsAreThosePlanRefusesAsUnreachable) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  // A robot for slopes under 7°: the 12° ramp is not for it, so floor and deck do not connect.
  v1::EstimateCostsRequest request =
      CostsRequest("demo", {kFloor, kDeck}, {kDeck, kOpenFloor, kUnderDeck, {14, 9, 3.3}});
  request.mutable_profile()->set_max_tilt_rad(0.12);
  v1::EstimateCostsResponse response;
  const grpc::Status status = Estimate(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  int unreachable = 0;
  for (int i = 0; i < request.starts_m_size(); ++i) {
    for (int j = 0; j < request.goals_m_size(); ++j) {
      const v1::CostCell& cell = response.cells(i * request.goals_m_size() + j);
      v1::PlanResponse plan;
      const CallError error = ErrorOf(Plan(PlanFor(request, i, j), &plan));
      const bool plan_unreachable = error.reason == "GOAL_UNREACHABLE";
      EXPECT_EQ(cell.reason() == "GOAL_UNREACHABLE", plan_unreachable)
          << i << " " << j << ": " << error.message;
      EXPECT_EQ(cell.reachable(), !plan_unreachable) << i << " " << j;
      unreachable += plan_unreachable;
    }
  }
  EXPECT_EQ(unreachable, 4);
}

TEST_F(DispatchTest, ARequestKeepOutZoneIsHonouredLikePlans) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::EstimateCostsRequest request = CostsRequest("demo", {kFloor}, {kDeck, kOpenFloor});
  // Across the ramp, from the floor to below the deck: the deck has no other way up.
  v1::Prism* zone = request.add_keep_out();
  for (const auto& [x, y] : {std::pair{5.0, 0.5}, {6.0, 0.5}, {6.0, 5.0}, {5.0, 5.0}}) {
    v1::Vector2* corner = zone->add_polygon_m();
    corner->set_x(x);
    corner->set_y(y);
  }
  zone->set_z_min_m(-1);
  zone->set_z_max_m(2.5);
  v1::EstimateCostsResponse response;
  ASSERT_TRUE(Estimate(request, &response).ok());
  EXPECT_EQ(response.cells(0).reason(), "GOAL_UNREACHABLE");
  EXPECT_TRUE(response.cells(1).reachable());
  v1::PlanRequest plan = PlanFor(request, 0, 0);
  *plan.add_keep_out() = *zone;
  v1::PlanResponse planned;
  EXPECT_EQ(ErrorOf(Plan(plan, &planned)).reason, "GOAL_UNREACHABLE");
}

TEST_F(DispatchTest, BadRequestsAreRefusedNamingTheFieldOrTheLimit) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-cost-cells", "4"}));
  v1::EstimateCostsResponse response;
  CallError error = ErrorOf(Estimate(CostsRequest("atlantis", {kFloor}, {kDeck}), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(error.reason, "MAP_NOT_FOUND");

  error = ErrorOf(Estimate(CostsRequest("demo", {}, {kDeck}), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ::testing::ElementsAre("starts_m"));

  const double nan = std::numeric_limits<double>::quiet_NaN();
  error = ErrorOf(Estimate(CostsRequest("demo", {kFloor}, {{1, nan, 0}}), &response));
  EXPECT_EQ(error.reason, "INVALID_INPUT");
  EXPECT_THAT(error.fields, ::testing::ElementsAre("goals_m[0].y"));

  error = ErrorOf(
      Estimate(CostsRequest("demo", {kFloor, kDeck, kOpenFloor}, {kDeck, kUnderDeck}), &response));
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(error.message, HasSubstr("--max-cost-cells"));

  v1::EstimateCostsRequest big_robot = CostsRequest("demo", {kFloor}, {kDeck});
  big_robot.mutable_profile()->set_footprint_radius_m(2.0);
  error = ErrorOf(Estimate(big_robot, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(error.reason, "PROFILE_MISMATCH");
  EXPECT_THAT(error.fields, ::testing::ElementsAre("profile.footprint_radius_m"));

  v1::EstimateCostsRequest bad_zone = CostsRequest("demo", {kFloor}, {kDeck});
  bad_zone.add_keep_out()->set_z_min_m(0);
  error = ErrorOf(Estimate(bad_zone, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  ASSERT_FALSE(error.fields.empty());
  EXPECT_THAT(error.fields[0], HasSubstr("keep_out[0]"));
}

// The searches use an idle slot too; with one slot, one.
TEST_F(DispatchTest, SearchesSpreadOverIdleSlots) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-concurrent-plans", "2"}));
  const v1::EstimateCostsRequest request =
      CostsRequest("demo", {kFloor, kOpenFloor, kUnderDeck, kDeck, {3, 9, 0.3}, {17, 10, 3.3}},
                   {kFloor, kOpenFloor, kUnderDeck, kDeck, {3, 9, 0.3}, {17, 10, 3.3}});
  v1::EstimateCostsResponse response;
  ASSERT_TRUE(Estimate(request, &response).ok());
  EXPECT_EQ(response.stats().searches(), 6);
  EXPECT_EQ(response.stats().slots_used(), 2);
}

// Many ends off the ground are slow to refuse (each names the nearest ground, found by a scan
// of the map): long enough to be caught in flight by a deadline or a cancellation.
v1::EstimateCostsRequest SlowCostsRequest() {
  std::vector<std::array<double, 3>> starts(20000, kOffMap);
  for (std::size_t i = 0; i < starts.size(); ++i) starts[i][0] += 0.01 * static_cast<double>(i);
  return CostsRequest("demo", starts, {kDeck});
}

TEST_F(DispatchTest, AnEstimateStopsAtItsDeadline) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-cost-cells", "20000"}));
  v1::EstimateCostsResponse response;
  // The robot's graph first, so that the stop is the estimate's own, not the graph build's.
  ASSERT_TRUE(Estimate(CostsRequest("demo", {kFloor}, {kDeck}), &response).ok());
  const auto start = Clock::now();
  const CallError error = ErrorOf(Estimate(SlowCostsRequest(), &response, 0.3));
  EXPECT_EQ(error.code, grpc::StatusCode::DEADLINE_EXCEEDED) << error.message;
  // The server stopped there too, saying why (the whole estimate takes seconds).
  const std::string line = RpcLogLine("EstimateCosts", std::chrono::seconds(30), 2);
  EXPECT_THAT(line, HasSubstr("reason=TIME_BUDGET_EXCEEDED"));
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(3));
}

TEST_F(DispatchTest, AnEstimateStopsWhenItsClientCancels) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-cost-cells", "20000"}));
  v1::EstimateCostsResponse warm_up;  // The robot's graph, as above.
  ASSERT_TRUE(Estimate(CostsRequest("demo", {kFloor}, {kDeck}), &warm_up).ok());
  grpc::ClientContext context;
  SetDeadline(&context, 60);
  grpc::Status status;
  v1::EstimateCostsResponse response;
  std::thread call(
      [&] { status = planner_->EstimateCosts(&context, SlowCostsRequest(), &response); });
  ASSERT_TRUE(WaitStarted("EstimateCosts", 2));
  const auto cancelled = Clock::now();
  context.TryCancel();
  call.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED);
  const std::string line = RpcLogLine("EstimateCosts", std::chrono::seconds(30), 2);
  EXPECT_THAT(line, HasSubstr("reason=CANCELLED"));
  EXPECT_LT(Clock::now() - cancelled, std::chrono::seconds(3));
}

// ---- PlanBatch -----------------------------------------------------------------------------

TEST_F(DispatchTest, ABatchAnswersEveryItemAndBadItemsFailAloneAsPlanWouldFail) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanBatchRequest batch;
  *batch.add_requests() = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  *batch.add_requests() = PlanRequestFor("atlantis", 2, 2, 0.3, 10, 10, 3.3);
  *batch.add_requests() = PlanRequestFor("demo", 50, 50, 0.3, 10, 10, 3.3);
  *batch.add_requests() = PlanRequestFor("demo", 8, 5.25, 0.3, 12, 9, 0.3);
  *batch.add_requests() =
      PlanRequestFor("demo", 2, std::numeric_limits<double>::infinity(), 0.3, 10, 10, 3.3);
  const BatchOutcome outcome = Batch(batch);
  ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
  ASSERT_EQ(outcome.results.size(), 5u);
  std::set<unsigned> seen;
  for (const v1::PlanBatchResponse& item : outcome.results) {
    ASSERT_LT(item.index(), 5u);
    EXPECT_TRUE(seen.insert(item.index()).second) << "index " << item.index() << " twice";
    const v1::PlanRequest& request = batch.requests(static_cast<int>(item.index()));
    v1::PlanResponse single;
    const grpc::Status alone = Plan(request, &single);
    if (item.index() == 0 || item.index() == 3) {
      ASSERT_EQ(item.result_case(), v1::PlanBatchResponse::kResponse) << item.index();
      EXPECT_GT(item.response().trajectory().pieces_size(), 0);
      EXPECT_FALSE(item.response().map_version().empty());
      continue;
    }
    ASSERT_EQ(item.result_case(), v1::PlanBatchResponse::kError) << item.index();
    // The item's error is the one Plan gives: code, message, ErrorInfo and BadRequest.
    const CallError expected = ErrorOf(alone);
    const CallError got =
        ErrorOf(grpc::Status(static_cast<grpc::StatusCode>(item.error().code()),
                             item.error().message(), item.error().SerializeAsString()));
    EXPECT_NE(expected.code, grpc::StatusCode::OK);
    EXPECT_EQ(got.code, expected.code) << item.index();
    EXPECT_EQ(got.message, expected.message) << item.index();
    EXPECT_EQ(got.reason, expected.reason) << item.index();
    EXPECT_EQ(got.domain, "strata");
    EXPECT_EQ(got.fields, expected.fields) << item.index();
  }
}

TEST_F(DispatchTest, ABatchIsRefusedWholeOnlyWhenEmptyOrTooLarge) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-batch-plans", "2"}));
  CallError error = ErrorOf(Batch(v1::PlanBatchRequest{}).status);
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ::testing::ElementsAre("requests"));
  v1::PlanBatchRequest batch;
  for (int i = 0; i < 3; ++i)
    *batch.add_requests() = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  error = ErrorOf(Batch(batch).status);
  EXPECT_EQ(error.code, grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(error.message, HasSubstr("--max-batch-plans"));
}

// A batch waits for slots in the same queue as Plan calls: a plan sent while a long batch
// runs on the one slot waits for about one of the batch's plans, not for the batch.
TEST_F(DispatchTest, ABatchSharesTheSlotsWithPlanCalls) {
  ASSERT_NO_FATAL_FAILURE(StartServer({"--max-concurrent-plans", "1"}));
  // The first plan for a profile builds its graph: on the demo map that took 40% of a
  // 16-plan batch, and a plan queued behind it waited more than a third of the batch (1 run
  // in 30 with the cores loaded). Built here, every plan of the batch takes about as long.
  const v1::PlanRequest request = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  v1::PlanResponse warm;
  ASSERT_TRUE(Plan(request, &warm).ok());
  v1::PlanBatchRequest batch;
  for (int i = 0; i < 16; ++i) *batch.add_requests() = request;
  BatchOutcome outcome;
  const auto start = Clock::now();
  Clock::duration batch_time{};
  std::thread batch_call([&] {
    outcome = Batch(batch);
    batch_time = Clock::now() - start;
  });
  ASSERT_TRUE(WaitStarted("PlanBatch", 1));
  v1::PlanResponse single;
  const grpc::Status planned = Plan(PlanRequestFor("demo", 8, 5.25, 0.3, 12, 9, 0.3), &single);
  batch_call.join();
  ASSERT_TRUE(planned.ok()) << planned.error_message();
  ASSERT_TRUE(outcome.status.ok());
  ASSERT_EQ(outcome.results.size(), 16u);
  const double batch_s = std::chrono::duration<double>(batch_time).count();
  EXPECT_LT(single.stats().timings().queue_s(), batch_s / 3)
      << "the plan waited " << single.stats().timings().queue_s() << " s of the batch's "
      << batch_s;
}

TEST_F(DispatchTest, ABatchStopsAtItsDeadline) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanBatchRequest batch;
  for (int i = 0; i < 2000; ++i)
    *batch.add_requests() = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  const auto start = Clock::now();
  const BatchOutcome outcome = Batch(batch, 0.5);
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_LT(outcome.results.size(), 2000u);
  // The server stopped there too, saying why.
  const std::string line = RpcLogLine("PlanBatch", std::chrono::seconds(30));
  EXPECT_THAT(line, HasSubstr("reason=TIME_BUDGET_EXCEEDED"));
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
}

TEST_F(DispatchTest, ABatchStopsWhenItsClientCancels) {
  ASSERT_NO_FATAL_FAILURE(StartServer());
  v1::PlanBatchRequest batch;
  for (int i = 0; i < 2000; ++i)
    *batch.add_requests() = PlanRequestFor("demo", 2, 2, 0.3, 10, 10, 3.3);
  grpc::ClientContext context;
  SetDeadline(&context, 120);
  auto reader = planner_->PlanBatch(&context, batch);
  v1::PlanBatchResponse item;
  ASSERT_TRUE(reader->Read(&item));  // Under way.
  const auto cancelled = Clock::now();
  context.TryCancel();
  while (reader->Read(&item)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  const std::string line = RpcLogLine("PlanBatch", std::chrono::seconds(30));
  EXPECT_THAT(line, HasSubstr("reason=CANCELLED"));
  EXPECT_LT(Clock::now() - cancelled, std::chrono::seconds(3));
}

}  // namespace
}  // namespace strata::server::testing
