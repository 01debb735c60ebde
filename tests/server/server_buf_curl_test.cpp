// The server through an independent client that knows no Strata proto: Buf's `buf curl`,
// which, like grpcurl, discovers the services by reflection and speaks JSON. This is what the
// README's grpcurl section promises. Buf's CLI is installed by scripts/install-test-tools.sh
// (from npm); without it the tests skip and say so.
#include <filesystem>
#include <string>
#include <vector>

#include <absl/strings/escaping.h>
#include <gmock/gmock.h>
#include <google/rpc/error_details.pb.h>
#include <nlohmann/json.hpp>

#include "server_fixture.hpp"
#include "test_util/run_command.hpp"

namespace strata::server::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

class BufCurlTest : public ServerFixture {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(STRATA_BUF_BIN)) {
      GTEST_SKIP() << STRATA_BUF_BIN << " not found: run scripts/install-test-tools.sh";
    }
    ASSERT_NO_FATAL_FAILURE(StartServer());
  }

  struct CurlOutcome {
    int exit_code = -1;
    std::string output;  ///< stdout, then stderr.
  };

  // `buf curl` over plaintext HTTP/2 to the test server; `rpc` empty lists the services.
  CurlOutcome Curl(const std::string& rpc, const std::string& json = "") {
    std::vector<std::string> argv = {
        STRATA_BUF_BIN, "curl", "--protocol", "grpc", "--http2-prior-knowledge",
        "--timeout",    "60s"};
    if (rpc.empty()) argv.push_back("--list-services");
    if (!json.empty()) argv.insert(argv.end(), {"-d", json});
    argv.push_back("http://" + server_->address() + (rpc.empty() ? "" : "/" + rpc));
    const test_util::CommandResult run = test_util::RunCommand(argv);
    return {run.exit_code, run.out + run.err};
  }
};

TEST_F(BufCurlTest, ReflectionListsEveryService) {
  const auto listed = Curl("");
  ASSERT_EQ(listed.exit_code, 0) << listed.output;
  EXPECT_THAT(listed.output,
              AllOf(HasSubstr("strata.v1.MapService"), HasSubstr("strata.v1.PlannerService"),
                    HasSubstr("grpc.health.v1.Health")));
}

TEST_F(BufCurlTest, HealthCheckAnswersServing) {
  const auto health = Curl("grpc.health.v1.Health/Check", R"({"service":""})");
  ASSERT_EQ(health.exit_code, 0) << health.output;
  EXPECT_THAT(health.output, HasSubstr(R"("status": "SERVING")"));
}

// The README's grpcurl Plan call, in JSON: the response carries pieces and stats.
TEST_F(BufCurlTest, PlansFromJsonAsTheReadmeShows) {
  const auto plan =
      Curl("strata.v1.PlannerService/Plan", R"({"map_id":"demo","profile_name":"differential",)"
                                            R"("start":{"position_m":{"x":2,"y":2,"z":0.3}},)"
                                            R"("goal":{"position_m":{"x":10,"y":10,"z":3.3}}})");
  ASSERT_EQ(plan.exit_code, 0) << plan.output;
  EXPECT_THAT(plan.output, AllOf(HasSubstr(R"("pieces")"), HasSubstr(R"("durationS")"),
                                 HasSubstr(R"("lengthM")")));
}

// proto/README.md's EstimateCosts call, as written there: every pair has its cell, the end off
// the map its reason.
TEST_F(BufCurlTest, EstimatesCostsAsProtoReadmeShows) {
  const auto costs =
      Curl("strata.v1.PlannerService/EstimateCosts",
           R"({"map_id":"demo","profile_name":"differential",)"
           R"("starts_m":[{"x":2,"y":2,"z":0.3},{"x":8,"y":5.25,"z":0.3},{"x":100,"y":100,"z":0}],)"
           R"("goals_m":[{"x":10,"y":10,"z":3.3},{"x":12,"y":9,"z":0.3}]})");
  ASSERT_EQ(costs.exit_code, 0) << costs.output;
  const nlohmann::json response = nlohmann::json::parse(costs.output, nullptr, false);
  ASSERT_TRUE(response.is_object()) << costs.output;
  ASSERT_EQ(response["cells"].size(), 6u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(response["cells"][k].value("reachable", false), true) << k;
    EXPECT_GT(response["cells"][k].value("timeS", 0.0), 0) << k;
  }
  EXPECT_EQ(response["cells"][4].value("reason", ""), "START_OFF_GROUND");
  EXPECT_THAT(response["starts"][2].value("message", ""), HasSubstr("the nearest is"));
}

// proto/README.md's route through a flow-through via and a stop, as written there: one
// trajectory, a time per via, the stop after the via.
TEST_F(BufCurlTest, PlansARouteThroughViasAsProtoReadmeShows) {
  const auto route = Curl("strata.v1.PlannerService/Plan",
                          R"({"map_id":"demo","profile_name":"differential",)"
                          R"("start":{"position_m":{"x":2,"y":5.2,"z":0.3}},)"
                          R"("goal":{"position_m":{"x":13,"y":8,"z":0.3}},)"
                          R"("via":[{"position_m":{"x":9,"y":2.75,"z":1.7}},)"
                          R"({"position_m":{"x":10,"y":10,"z":3.3},"stop":true}]})");
  ASSERT_EQ(route.exit_code, 0) << route.output;
  const nlohmann::json response = nlohmann::json::parse(route.output, nullptr, false);
  ASSERT_TRUE(response.is_object()) << route.output;
  ASSERT_EQ(response["viaTimesS"].size(), 2u) << route.output;
  const double passed = response["viaTimesS"][0].get<double>();
  const double stopped = response["viaTimesS"][1].get<double>();
  EXPECT_GT(passed, 0);
  EXPECT_GT(stopped, passed);
}

// proto/README.md's PlanBatch call: two results streamed, the bad item with Plan's error.
TEST_F(BufCurlTest, StreamsABatchAsProtoReadmeShows) {
  const auto batch = Curl(
      "strata.v1.PlannerService/PlanBatch",
      R"({"requests":[)"
      R"({"map_id":"demo","profile_name":"differential",)"
      R"("start":{"position_m":{"x":2,"y":2,"z":0.3}},"goal":{"position_m":{"x":10,"y":10,"z":3.3}}},)"
      R"({"map_id":"demo","profile_name":"differential",)"
      R"("start":{"position_m":{"x":50,"y":50,"z":0.3}},"goal":{"position_m":{"x":10,"y":10,"z":3.3}}}]})");
  ASSERT_EQ(batch.exit_code, 0) << batch.output;
  // One JSON object per result, one after the other.
  std::vector<nlohmann::json> results;
  std::size_t at = 0;
  while (at < batch.output.size()) {
    const std::size_t begin = batch.output.find('{', at);
    if (begin == std::string::npos) break;
    int depth = 0;
    std::size_t end = begin;
    for (; end < batch.output.size(); ++end) {
      depth += batch.output[end] == '{' ? 1 : batch.output[end] == '}' ? -1 : 0;
      if (depth == 0) break;
    }
    results.push_back(nlohmann::json::parse(batch.output.substr(begin, end - begin + 1)));
    at = end + 1;
  }
  ASSERT_EQ(results.size(), 2u) << batch.output;
  for (const nlohmann::json& result : results) {
    if (result.value("index", -1) == 0) {
      EXPECT_TRUE(result.contains("response")) << result.dump();
    } else {
      EXPECT_EQ(result.value("index", -1), 1) << result.dump();
      EXPECT_EQ(result["error"].value("code", 0), 3);
      EXPECT_THAT(result["error"].dump(), HasSubstr("START_OFF_GROUND"));
      EXPECT_THAT(result["error"].dump(), HasSubstr("start.position_m"));
    }
  }
}

// Errors reach a JSON client with their code, message and google.rpc.ErrorInfo (which buf
// prints as base64 of the packed message, having no descriptor for it).
TEST_F(BufCurlTest, ErrorsCarryTheirCodeMessageAndReason) {
  const auto missing = Curl("strata.v1.MapService/GetMap", R"({"map_id":"no-such-map"})");
  EXPECT_NE(missing.exit_code, 0);
  const nlohmann::json error = nlohmann::json::parse(missing.output, nullptr, false);
  ASSERT_TRUE(error.is_object()) << missing.output;
  EXPECT_EQ(error.value("code", ""), "not_found");
  EXPECT_THAT(error.value("message", ""), HasSubstr("ListMaps shows the maps it holds"));
  bool found_info = false;
  for (const nlohmann::json& detail : error.value("details", nlohmann::json::array())) {
    if (detail.value("type", "") != "google.rpc.ErrorInfo") continue;
    std::string bytes;
    // buf prints unpadded base64; pad it for the decoder.
    std::string value = detail.value("value", "");
    value.append((4 - value.size() % 4) % 4, '=');
    ASSERT_TRUE(absl::Base64Unescape(value, &bytes));
    google::rpc::ErrorInfo info;
    ASSERT_TRUE(info.ParseFromString(bytes));
    EXPECT_EQ(info.reason(), "MAP_NOT_FOUND");
    EXPECT_EQ(info.domain(), "strata");
    found_info = true;
  }
  EXPECT_TRUE(found_info) << missing.output;
}

}  // namespace
}  // namespace strata::server::testing
