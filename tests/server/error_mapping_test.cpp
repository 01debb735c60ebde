// The one table from failures to gRPC codes and reasons, and the richer error details.
#include "rpc/error_mapping.hpp"

#include <cctype>
#include <set>

#include <google/rpc/error_details.pb.h>
#include <google/rpc/status.pb.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using grpc::StatusCode;

// Every planner code, by walking the enum up to its last value.
std::vector<ErrorCode> AllPlannerCodes() {
  std::vector<ErrorCode> codes;
  for (int i = 0; i <= static_cast<int>(ErrorCode::kReservationConflict); ++i) {
    codes.push_back(static_cast<ErrorCode>(i));
  }
  return codes;
}

bool IsUpperSnakeCase(std::string_view text) {
  if (text.empty() || text.front() == '_' || text.back() == '_') return false;
  for (const char c : text) {
    if (!(std::isupper(static_cast<unsigned char>(c)) ||
          std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
      return false;
  }
  return true;
}

TEST(ErrorMappingTest, EveryCodeHasExactlyOneRowWithAUniqueUpperSnakeReason) {
  std::vector<ServiceError::Code> all;
  for (ErrorCode code : AllPlannerCodes()) all.emplace_back(code);
  for (ServiceErrorCode code : kAllServiceErrorCodes) all.emplace_back(code);
  EXPECT_EQ(ErrorMappingTable().size(), all.size());
  std::set<std::string_view> reasons;
  for (const ServiceError::Code& code : all) {
    int rows = 0;
    for (const ErrorMapping& row : ErrorMappingTable()) rows += row.code == code ? 1 : 0;
    EXPECT_EQ(rows, 1) << MapError(code).reason;
    const ErrorMapping mapping = MapError(code);
    EXPECT_TRUE(IsUpperSnakeCase(mapping.reason)) << mapping.reason;
    EXPECT_TRUE(reasons.insert(mapping.reason).second) << "duplicate " << mapping.reason;
    EXPECT_NE(mapping.grpc_code, StatusCode::OK);
    EXPECT_NE(mapping.grpc_code, StatusCode::UNKNOWN);
  }
}

// The documented mapping (proto/README.md), row by row.
TEST(ErrorMappingTest, MapsAsDocumented) {
  const struct {
    ServiceError::Code code;
    StatusCode grpc_code;
    const char* reason;
  } expected[] = {
      {ErrorCode::kInvalidInput, StatusCode::INVALID_ARGUMENT, "INVALID_INPUT"},
      {ErrorCode::kInvalidConfig, StatusCode::INVALID_ARGUMENT, "INVALID_CONFIG"},
      {ErrorCode::kMapLoadFailed, StatusCode::INVALID_ARGUMENT, "MAP_LOAD_FAILED"},
      {ErrorCode::kResourceExhausted, StatusCode::RESOURCE_EXHAUSTED, "RESOURCE_EXHAUSTED"},
      {ErrorCode::kStartOffGround, StatusCode::INVALID_ARGUMENT, "START_OFF_GROUND"},
      {ErrorCode::kGoalOffGround, StatusCode::INVALID_ARGUMENT, "GOAL_OFF_GROUND"},
      {ErrorCode::kStartInKeepOut, StatusCode::INVALID_ARGUMENT, "START_IN_KEEP_OUT"},
      {ErrorCode::kGoalInKeepOut, StatusCode::INVALID_ARGUMENT, "GOAL_IN_KEEP_OUT"},
      {ErrorCode::kGoalUnreachable, StatusCode::FAILED_PRECONDITION, "GOAL_UNREACHABLE"},
      {ErrorCode::kNoPath, StatusCode::FAILED_PRECONDITION, "NO_PATH"},
      {ErrorCode::kDeadlineExceeded, StatusCode::DEADLINE_EXCEEDED, "TIME_BUDGET_EXCEEDED"},
      {ErrorCode::kCancelled, StatusCode::CANCELLED, "CANCELLED"},
      {ErrorCode::kSearchBudgetExhausted, StatusCode::RESOURCE_EXHAUSTED,
       "SEARCH_BUDGET_EXHAUSTED"},
      {ErrorCode::kProfileMismatch, StatusCode::FAILED_PRECONDITION, "PROFILE_MISMATCH"},
      {ErrorCode::kOptimizationFailed, StatusCode::ABORTED, "OPTIMIZATION_FAILED"},
      {ErrorCode::kReservationConflict, StatusCode::FAILED_PRECONDITION, "RESERVATION_CONFLICT"},
      {ServiceErrorCode::kMapNotFound, StatusCode::NOT_FOUND, "MAP_NOT_FOUND"},
      {ServiceErrorCode::kMapNotActive, StatusCode::FAILED_PRECONDITION, "MAP_NOT_ACTIVE"},
      {ServiceErrorCode::kMapAlreadyExists, StatusCode::ALREADY_EXISTS, "MAP_ALREADY_EXISTS"},
      {ServiceErrorCode::kTooManyMaps, StatusCode::RESOURCE_EXHAUSTED, "TOO_MANY_MAPS"},
      {ServiceErrorCode::kPathOutsideMapRoot, StatusCode::PERMISSION_DENIED,
       "PATH_OUTSIDE_MAP_ROOT"},
      {ServiceErrorCode::kServerBusy, StatusCode::UNAVAILABLE, "SERVER_BUSY"},
      {ServiceErrorCode::kShuttingDown, StatusCode::UNAVAILABLE, "SHUTTING_DOWN"},
      {ServiceErrorCode::kInternal, StatusCode::INTERNAL, "INTERNAL"},
      {ServiceErrorCode::kMapVersionNotFound, StatusCode::NOT_FOUND, "MAP_VERSION_NOT_FOUND"},
      {ServiceErrorCode::kMapChanged, StatusCode::ABORTED, "MAP_CHANGED"},
      {ServiceErrorCode::kMapStoreUnavailable, StatusCode::UNAVAILABLE, "MAP_STORE_UNAVAILABLE"},
      {ServiceErrorCode::kMapCorrupted, StatusCode::DATA_LOSS, "MAP_CORRUPTED"},
      {ServiceErrorCode::kMapStoreRequired, StatusCode::FAILED_PRECONDITION, "MAP_STORE_REQUIRED"},
      {ServiceErrorCode::kEditNeedsCloud, StatusCode::FAILED_PRECONDITION, "EDIT_NEEDS_CLOUD"},
      {ServiceErrorCode::kUnauthenticated, StatusCode::UNAUTHENTICATED, "UNAUTHENTICATED"},
      {ServiceErrorCode::kPermissionDenied, StatusCode::PERMISSION_DENIED, "PERMISSION_DENIED"},
      {ServiceErrorCode::kReservationNotFound, StatusCode::NOT_FOUND, "RESERVATION_NOT_FOUND"},
      {ServiceErrorCode::kSharedStateUnavailable, StatusCode::UNAVAILABLE,
       "SHARED_STATE_UNAVAILABLE"},
  };
  EXPECT_EQ(std::size(expected), ErrorMappingTable().size());
  for (const auto& row : expected) {
    const ErrorMapping mapping = MapError(row.code);
    EXPECT_EQ(mapping.grpc_code, row.grpc_code) << row.reason;
    EXPECT_EQ(mapping.reason, row.reason);
  }
}

TEST(ErrorMappingTest, PacksErrorInfoAndBadRequestIntoTheStatusDetails) {
  ServiceError error = MakeError(ErrorCode::kInvalidInput, "start.position_m.x must be finite")
                           .Blame("start.position_m.x")
                           .With("map_id", "demo");
  const grpc::Status status = ToGrpcStatus(error);
  EXPECT_EQ(status.error_code(), StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "start.position_m.x must be finite");

  google::rpc::Status details;
  ASSERT_TRUE(details.ParseFromString(status.error_details()));
  EXPECT_EQ(details.code(), static_cast<int>(StatusCode::INVALID_ARGUMENT));
  EXPECT_EQ(details.message(), status.error_message());
  ASSERT_EQ(details.details_size(), 2);
  google::rpc::ErrorInfo info;
  ASSERT_TRUE(details.details(0).UnpackTo(&info));
  EXPECT_EQ(info.reason(), "INVALID_INPUT");
  EXPECT_EQ(info.domain(), "strata");
  EXPECT_EQ(info.metadata().at("map_id"), "demo");
  google::rpc::BadRequest bad_request;
  ASSERT_TRUE(details.details(1).UnpackTo(&bad_request));
  ASSERT_EQ(bad_request.field_violations_size(), 1);
  EXPECT_EQ(bad_request.field_violations(0).field(), "start.position_m.x");
}

TEST(ErrorMappingTest, NoBadRequestWhenNoFieldIsBlamed) {
  const grpc::Status status =
      ToGrpcStatus(MakeError(ServiceErrorCode::kMapNotActive, "map 'x' is CREATING"));
  google::rpc::Status details;
  ASSERT_TRUE(details.ParseFromString(status.error_details()));
  ASSERT_EQ(details.details_size(), 1);
  EXPECT_TRUE(details.details(0).Is<google::rpc::ErrorInfo>());
}

}  // namespace
}  // namespace strata::server

namespace strata::server {
namespace {

// A message may quote what a client sent; whatever it sent, what goes back stays small enough
// for the usual 8 KiB metadata limit of clients (a 1 MiB name once came back as 3 MB).
TEST(ErrorMappingTest, EveryEchoedStringIsBounded) {
  const std::string huge(1 << 20, 'a');
  ServiceError error = MakeError(ErrorCode::kInvalidInput, "unknown robot profile " + huge);
  error.With("profile_name", huge).With(huge, "value");
  for (int i = 0; i < 100; ++i) error.Blame(huge);
  const grpc::Status status = ToGrpcStatus(error);
  EXPECT_LE(status.error_message().size(), kMaxErrorMessageBytes + 32);
  EXPECT_NE(status.error_message().find("more bytes]"), std::string::npos);
  EXPECT_LE(status.error_details().size(), 8u * 1024);
  google::rpc::Status details;
  ASSERT_TRUE(details.ParseFromString(status.error_details()));
  google::rpc::ErrorInfo info;
  ASSERT_TRUE(details.details(0).UnpackTo(&info));
  EXPECT_EQ(info.reason(), "INVALID_INPUT");
  for (const auto& [key, value] : info.metadata()) {
    EXPECT_LE(key.size(), kMaxErrorValueBytes + 32);
    EXPECT_LE(value.size(), kMaxErrorValueBytes + 32);
  }
}

TEST(ErrorMappingTest, BoundedTextCutsOnACharacterBoundary) {
  EXPECT_EQ(BoundedText("short", 8), "short");
  EXPECT_EQ(BoundedText("abcdefghij", 4), "abcd…[6 more bytes]");
  // "é" is two bytes: a cut inside it backs off to before it.
  EXPECT_EQ(BoundedText("abcé", 4), "abc…[2 more bytes]");
}

}  // namespace
}  // namespace strata::server
