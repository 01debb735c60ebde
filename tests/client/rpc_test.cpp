// DescribeStatus unpacks the details strata-server packs (see server/rpc/error_mapping.cpp), and
// the CLI's error report prints them, as text and as JSON.
#include "strata/client/rpc.hpp"

#include <sstream>

#include <gmock/gmock.h>
#include <google/rpc/error_details.pb.h>
#include <google/rpc/status.pb.h>
#include <gtest/gtest.h>

#include "output.hpp"

namespace strata::client {
namespace {

using ::testing::HasSubstr;

grpc::Status StatusWithDetails() {
  google::rpc::Status details;
  details.set_code(grpc::StatusCode::INVALID_ARGUMENT);
  details.set_message("start (1, 2, 3) m is off the ground");
  google::rpc::ErrorInfo info;
  info.set_reason("START_OFF_GROUND");
  info.set_domain("strata");
  (*info.mutable_metadata())["map_id"] = "demo";
  details.add_details()->PackFrom(info);
  google::rpc::BadRequest bad_request;
  auto* violation = bad_request.add_field_violations();
  violation->set_field("start.position_m");
  violation->set_description("nearest valid ground is (1, 2, 0.3)");
  details.add_details()->PackFrom(bad_request);
  return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, details.message(),
                      details.SerializeAsString());
}

TEST(RpcTest, DescribeStatusUnpacksErrorInfoAndBadRequest) {
  const RpcError error = DescribeStatus(StatusWithDetails());
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error.code_name, "INVALID_ARGUMENT");
  EXPECT_EQ(error.message, "start (1, 2, 3) m is off the ground");
  EXPECT_EQ(error.reason, "START_OFF_GROUND");
  EXPECT_EQ(error.domain, "strata");
  EXPECT_EQ(error.metadata.at("map_id"), "demo");
  ASSERT_EQ(error.field_violations.size(), 1u);
  EXPECT_EQ(error.field_violations[0].first, "start.position_m");
  EXPECT_EQ(error.field_violations[0].second, "nearest valid ground is (1, 2, 0.3)");
}

TEST(RpcTest, DescribeStatusWithoutDetailsKeepsCodeAndMessage) {
  const RpcError error =
      DescribeStatus(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "Deadline Exceeded"));
  EXPECT_EQ(error.code_name, "DEADLINE_EXCEEDED");
  EXPECT_EQ(error.message, "Deadline Exceeded");
  EXPECT_TRUE(error.reason.empty());
  EXPECT_TRUE(error.field_violations.empty());
  EXPECT_EQ(DescribeStatus(grpc::Status(grpc::StatusCode::INTERNAL, "x", "not a proto\xff")).reason,
            "");
  // 20: no code has it, yet within the enum's range (42 would be undefined behaviour).
  EXPECT_EQ(StatusCodeName(static_cast<grpc::StatusCode>(20)), "UNKNOWN_CODE_20");
}

TEST(RpcTest, ErrorReportPrintsCodeReasonAndFields) {
  std::ostringstream out, err;
  cli::Context ctx;
  ctx.out = &out;
  ctx.err = &err;
  EXPECT_EQ(cli::ReportRpcError(ctx, "Plan", StatusWithDetails()), cli::kExitRpcError);
  EXPECT_THAT(err.str(), HasSubstr("Plan failed: INVALID_ARGUMENT: start (1, 2, 3) m is off"));
  EXPECT_THAT(err.str(), HasSubstr("reason: START_OFF_GROUND (domain strata)"));
  EXPECT_THAT(err.str(), HasSubstr("map_id: demo"));
  EXPECT_THAT(err.str(), HasSubstr("bad field start.position_m: nearest valid ground"));
  EXPECT_TRUE(out.str().empty());

  std::ostringstream json_err;
  ctx.err = &json_err;
  ctx.json = true;
  cli::ReportRpcError(ctx, "Plan", StatusWithDetails());
  EXPECT_THAT(json_err.str(), HasSubstr("\"code\": \"INVALID_ARGUMENT\", \"code_number\": 3"));
  EXPECT_THAT(json_err.str(), HasSubstr("\"reason\": \"START_OFF_GROUND\""));
  EXPECT_THAT(json_err.str(), HasSubstr("{\"field\": \"start.position_m\""));
}

TEST(RpcTest, JsonHelpersEscapeAndRoundTrip) {
  EXPECT_EQ(cli::JsonString("a\"b\\c\n\x01"), "\"a\\\"b\\\\c\\n\\u0001\"");
  for (double value : {0.1, -1.0 / 3, 1e-300, 12345.678901234567}) {
    EXPECT_EQ(std::stod(cli::JsonNumber(value)), value);
  }
}

}  // namespace
}  // namespace strata::client
