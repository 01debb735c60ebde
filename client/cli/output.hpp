#pragma once
// Output of the strata CLI: protobuf JSON with stable keys, readable numbers and vectors,
// and error reports with the richer error model's details.
#include <string>

#include <google/protobuf/message.h>
#include <google/protobuf/timestamp.pb.h>
#include <grpcpp/grpcpp.h>

#include "context.hpp"
#include "strata/v1/common.pb.h"

namespace strata::cli {

/// The message as JSON: proto field names (snake_case, as in the .proto files and
/// proto/README.md), every field printed even when zero (keys do not come and go), indented.
std::string ToJson(const google::protobuf::Message& message);

/// The message as one line of compact JSON (proto field names), newline included: a stream's
/// items as JSON lines.
std::string ToJsonLine(const google::protobuf::Message& message);

/// Parses JSON (as ToJson or grpcurl print it) into `message`; throws UsageError naming
/// `what` when it is not valid JSON for the message.
void FromJson(const std::string& json, const std::string& what, google::protobuf::Message* message);

/// Reads a whole file; throws UsageError when it cannot be read.
std::string ReadFile(const std::string& path);

/// "(x, y, z)" with 3 decimals.
std::string FormatVector(const v1::Vector3& v);
/// An absolute time as RFC 3339 in UTC ("2026-11-29T05:01:02.500Z").
std::string FormatTime(const google::protobuf::Timestamp& time);
/// A number with `decimals` decimals.
std::string Fixed(double value, int decimals);
/// A number that reads back as the same double (shortest round-trip form).
std::string JsonNumber(double value);
/// `text` as a JSON string literal, quotes included.
std::string JsonString(const std::string& text);

/// Prints a failed call to ctx.err (as JSON with --json): code, message, ErrorInfo reason,
/// domain and metadata, BadRequest field violations. Returns kExitRpcError.
int ReportRpcError(const Context& ctx, const std::string& rpc, const grpc::Status& status);

}  // namespace strata::cli
