#include "output.hpp"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/time_util.h>

#include "context.hpp"
#include "strata/client/rpc.hpp"

namespace strata::cli {

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
  if (!status.ok()) return "{\"error\": " + JsonString(status.ToString()) + "}\n";
  return json;
}

void FromJson(const std::string& json, const std::string& what,
              google::protobuf::Message* message) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, message, options);
  if (!status.ok()) {
    throw UsageError(what + " is not a valid " + message->GetDescriptor()->full_name() +
                     " in JSON: " + std::string(status.message()));
  }
}

std::string ReadFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw UsageError("cannot read \"" + path + "\"");
  std::ostringstream contents;
  contents << file.rdbuf();
  return contents.str();
}

std::string ToJsonLine(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json + "\n";
}

std::string FormatTime(const google::protobuf::Timestamp& time) {
  return google::protobuf::util::TimeUtil::ToString(time);
}

std::string Fixed(double value, int decimals) { return fmt::format("{:.{}f}", value, decimals); }

std::string FormatVector(const v1::Vector3& v) {
  return fmt::format("({:.3f}, {:.3f}, {:.3f})", v.x(), v.y(), v.z());
}

std::string JsonNumber(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string JsonString(const std::string& text) {
  std::string quoted = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': quoted += "\\\""; break;
      case '\\': quoted += "\\\\"; break;
      case '\n': quoted += "\\n"; break;
      case '\t': quoted += "\\t"; break;
      case '\r': quoted += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", c);
          quoted += escaped;
        } else {
          quoted += c;
        }
    }
  }
  return quoted + "\"";
}

int ReportRpcError(const Context& ctx, const std::string& rpc, const grpc::Status& status) {
  const client::RpcError error = client::DescribeStatus(status);
  std::ostream& err = *ctx.err;
  if (ctx.json) {
    err << "{\"error\": {\"rpc\": " << JsonString(rpc)
        << ", \"code\": " << JsonString(error.code_name)
        << ", \"code_number\": " << static_cast<int>(error.code)
        << ", \"message\": " << JsonString(error.message)
        << ", \"reason\": " << JsonString(error.reason)
        << ", \"domain\": " << JsonString(error.domain) << ", \"metadata\": {";
    const char* separator = "";
    for (const auto& [key, value] : error.metadata) {
      err << separator << JsonString(key) << ": " << JsonString(value);
      separator = ", ";
    }
    err << "}, \"field_violations\": [";
    separator = "";
    for (const auto& [field, description] : error.field_violations) {
      err << separator << "{\"field\": " << JsonString(field)
          << ", \"description\": " << JsonString(description) << "}";
      separator = ", ";
    }
    err << "]}}\n";
    return kExitRpcError;
  }
  err << "strata: " << rpc << " failed: " << error.code_name << ": " << error.message << "\n";
  if (!error.reason.empty()) {
    err << "  reason: " << error.reason;
    if (!error.domain.empty()) err << " (domain " << error.domain << ")";
    err << "\n";
  }
  for (const auto& [key, value] : error.metadata) err << "  " << key << ": " << value << "\n";
  for (const auto& [field, description] : error.field_violations) {
    err << "  bad field " << field << ": " << description << "\n";
  }
  if (error.code == grpc::StatusCode::UNAVAILABLE && error.reason.empty()) {
    err << "  (is strata-server running at " << ctx.server << "? set --server or STRATA_SERVER)\n";
  }
  return kExitRpcError;
}

}  // namespace strata::cli
