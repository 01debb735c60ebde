// The documented defaults of the public API are the C++ defaults. Every proto3 `optional`
// scalar field reachable from PlanRequest and EstimateCostsRequest, and every field of
// TerrainParameters, must say
// "Default <value>." in its comment (`none` when unset means "off"), and <value> must be what
// the server uses when the field is unset: the test converts a request with every field unset
// through the server's converters (proto_convert) and reads the result back with the ToProto
// functions, so no value is kept by hand here. The comments come from the .proto files as
// protoc reads them (a descriptor set with source info, built by tests/server/CMakeLists.txt).
#include <cmath>
#include <fstream>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include "ops/flags.hpp"
#include "rpc/planner_service.hpp"
#include "rpc/proto_convert.hpp"
#include "strata/assessment/map_edit.hpp"

namespace strata::server {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::DescriptorPool;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

// The .proto files as written: descriptors with their comments.
const DescriptorPool& DocumentedPool() {
  static const DescriptorPool* pool = [] {
    google::protobuf::FileDescriptorSet set;
    std::ifstream in(STRATA_API_DESCRIPTORS, std::ios::binary);
    auto* result = new DescriptorPool;
    if (!set.ParseFromIstream(&in)) return result;
    for (const google::protobuf::FileDescriptorProto& file : set.file()) result->BuildFile(file);
    return result;
  }();
  return *pool;
}

// "Default <value>" in the field's leading comment, without a trailing full stop; nullopt
// when the comment gives none.
std::optional<std::string> DocumentedDefault(const FieldDescriptor* field) {
  google::protobuf::SourceLocation location;
  if (!field->GetSourceLocation(&location)) return std::nullopt;
  static const std::regex kDefault(R"(Default\s+("[^"]*"|[^\s(]+))");
  std::smatch match;
  if (!std::regex_search(location.leading_comments, match, kDefault)) return std::nullopt;
  std::string value = match[1];
  while (!value.empty() && (value.back() == '.' || value.back() == ',')) value.pop_back();
  return value;
}

// How far a documented number may be from the C++ value: 0.4 units of its last digit
// ("0.349" -> 4e-4, "1e4" -> 4e3, "2" -> 0.4), so a rounded value such as 0.349 for 20° passes
// but a near-tie does not ("0.1" for 0.15 fails: write the digits that decide it).
double RoundingTolerance(const std::string& number) {
  const std::size_t e = number.find_first_of("eE");
  const std::string mantissa = number.substr(0, e);
  const std::size_t dot = mantissa.find('.');
  const int decimals = dot == std::string::npos ? 0 : static_cast<int>(mantissa.size() - dot - 1);
  const int exponent = e == std::string::npos ? 0 : std::stoi(number.substr(e + 1));
  return 0.4 * std::pow(10.0, exponent - decimals);
}

// An optional scalar field of the API and its path from the root message ("options.weights.time").
struct OptionalField {
  std::string path;
  const FieldDescriptor* field;
};

void CollectOptionalFields(const Descriptor* message, const std::string& prefix,
                           std::vector<OptionalField>* out) {
  for (int i = 0; i < message->field_count(); ++i) {
    const FieldDescriptor* field = message->field(i);
    const std::string path = prefix + field->name();
    if (field->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
      // The elements of a repeated message (a keep-out Prism) are given whole, never defaulted
      // field by field.
      if (field->is_repeated()) continue;
      CollectOptionalFields(field->message_type(), path + ".", out);
    } else if (field->has_optional_keyword()) {
      out->push_back({path, field});
    }
  }
}

// The field at `path` of `message` (generated types: found by name), or nullptr where a
// message on the way or the field itself is unset.
const Message* Parent(const Message& message, const std::string& path, std::string* leaf) {
  const Message* current = &message;
  std::size_t begin = 0;
  for (std::size_t dot = path.find('.'); dot != std::string::npos; dot = path.find('.', begin)) {
    const FieldDescriptor* f =
        current->GetDescriptor()->FindFieldByName(path.substr(begin, dot - begin));
    if (f == nullptr || !current->GetReflection()->HasField(*current, f)) return nullptr;
    current = &current->GetReflection()->GetMessage(*current, f);
    begin = dot + 1;
  }
  *leaf = path.substr(begin);
  return current;
}

// What the C++ side uses for `path` when the request leaves it unset: "none", or the value.
std::string CppDefault(const Message& defaults, const std::string& path, double* number) {
  std::string leaf;
  const Message* parent = Parent(defaults, path, &leaf);
  if (parent == nullptr) return "none";
  const FieldDescriptor* f = parent->GetDescriptor()->FindFieldByName(leaf);
  const google::protobuf::Reflection* r = parent->GetReflection();
  if (f == nullptr || !r->HasField(*parent, f)) return "none";
  switch (f->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE: *number = r->GetDouble(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_FLOAT: *number = r->GetFloat(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_INT32: *number = r->GetInt32(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_UINT32: *number = r->GetUInt32(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_INT64: *number = r->GetInt64(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_UINT64: *number = r->GetUInt64(*parent, f); return "number";
    case FieldDescriptor::CPPTYPE_BOOL: return r->GetBool(*parent, f) ? "true" : "false";
    case FieldDescriptor::CPPTYPE_STRING: return "\"" + r->GetString(*parent, f) + "\"";
    default: return "unsupported";
  }
}

// Checks every optional field of `documented` against `defaults` (the same message type,
// generated, filled by the converters); returns how many fields were checked.
int ExpectDocumentedDefaults(const Descriptor* documented, const Message& defaults) {
  std::vector<OptionalField> fields;
  CollectOptionalFields(documented, "", &fields);
  for (const OptionalField& f : fields) {
    const std::optional<std::string> doc = DocumentedDefault(f.field);
    const bool numeric = f.field->cpp_type() != FieldDescriptor::CPPTYPE_BOOL &&
                         f.field->cpp_type() != FieldDescriptor::CPPTYPE_STRING &&
                         f.field->cpp_type() != FieldDescriptor::CPPTYPE_ENUM;
    if (!doc.has_value()) {
      ADD_FAILURE() << documented->name() << "." << f.path
                    << " is optional but its comment gives no \"Default <value>.\""
                    << (numeric ? "" : " (not numeric)");
      continue;
    }
    double cpp_number = 0;
    const std::string cpp = CppDefault(defaults, f.path, &cpp_number);
    if (cpp != "number" || *doc == "none") {
      EXPECT_EQ(*doc, cpp) << documented->name() << "." << f.path
                           << ": the comment's default differs from the C++ default";
      continue;
    }
    double doc_number = 0;
    try {
      doc_number = std::stod(*doc);
    } catch (const std::exception&) {
      ADD_FAILURE() << documented->name() << "." << f.path << ": default '" << *doc
                    << "' is not a number";
      continue;
    }
    EXPECT_LE(std::abs(doc_number - cpp_number), RoundingTolerance(*doc))
        << documented->name() << "." << f.path << ": the comment says Default " << *doc
        << ", the C++ default is " << cpp_number;
  }
  return static_cast<int>(fields.size());
}

TEST(ProtoDefaults, DocumentedPlanRequestDefaultsAreTheCppDefaults) {
  const Descriptor* documented = DocumentedPool().FindMessageTypeByName("strata.v1.PlanRequest");
  ASSERT_NE(documented, nullptr) << "cannot read " << STRATA_API_DESCRIPTORS;

  // A request with every optional field unset (an inline profile, so the profile's defaults
  // apply), converted as the server converts it, and read back.
  v1::PlanRequest unset;
  unset.set_map_id("m");
  unset.mutable_profile();
  unset.mutable_start()->mutable_position_m();
  unset.mutable_goal()->mutable_position_m();
  unset.mutable_fleet();
  Result<ParsedPlanRequest> parsed = ParsePlanRequest(unset);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  v1::PlanRequest defaults;
  // The fleet block's: the planner's, and the server's flags' that a plan applies.
  const ParsedFleet& fleet = parsed->fleet.value();
  const ServerConfig server;
  defaults.mutable_fleet()->set_avoid_reservations(fleet.avoid_reservations);
  defaults.mutable_fleet()->set_max_wait_s(fleet.options.max_wait_s);
  defaults.mutable_fleet()->set_lease_s(fleet.lease_s.value_or(server.default_lease_s));
  defaults.mutable_fleet()->set_separation_m(fleet.separation_m.value_or(server.separation_m));
  ToProto(parsed->plan.profile, defaults.mutable_profile());
  ToProto(parsed->plan.options, defaults.mutable_options());
  if (parsed->sample_dt_s.has_value()) {
    defaults.mutable_options()->set_sample_dt_s(*parsed->sample_dt_s);
  }
  defaults.mutable_options()->set_return_search_path(parsed->return_search_path);
  // RobotProfile (14), PlanOptions (4) and CostWeights (7) at least.
  EXPECT_GE(ExpectDocumentedDefaults(documented, defaults), 25);
}

TEST(ProtoDefaults, DocumentedEstimateCostsDefaultsAreTheCppDefaults) {
  const Descriptor* documented =
      DocumentedPool().FindMessageTypeByName("strata.v1.EstimateCostsRequest");
  ASSERT_NE(documented, nullptr) << "cannot read " << STRATA_API_DESCRIPTORS;
  v1::EstimateCostsRequest unset;
  unset.set_map_id("m");
  unset.mutable_profile();
  Result<ParsedCostRequest> parsed = ParseEstimateCostsRequest(unset, 1);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  v1::EstimateCostsRequest defaults;
  ToProto(parsed->profile, defaults.mutable_profile());
  defaults.set_snap_tolerance_m(parsed->snap_tolerance_m);
  // RobotProfile (14) and snap_tolerance_m.
  EXPECT_GE(ExpectDocumentedDefaults(documented, defaults), 15);
}

TEST(ProtoDefaults, DocumentedTerrainDefaultsAreTheCppDefaults) {
  const Descriptor* documented =
      DocumentedPool().FindMessageTypeByName("strata.v1.TerrainParameters");
  ASSERT_NE(documented, nullptr) << "cannot read " << STRATA_API_DESCRIPTORS;
  Result<AssessmentConfig> config = FromProto(v1::TerrainParameters(), "terrain");
  ASSERT_TRUE(config.ok()) << config.error().message;
  v1::TerrainParameters defaults;
  ToProto(config.value(), &defaults);
  EXPECT_EQ(ExpectDocumentedDefaults(documented, defaults), documented->field_count());
}

TEST(ProtoDefaults, RoundingToleranceFollowsTheLastDigitWritten) {
  EXPECT_DOUBLE_EQ(RoundingTolerance("0.349"), 4e-4);
  EXPECT_DOUBLE_EQ(RoundingTolerance("1e4"), 4e3);
  EXPECT_DOUBLE_EQ(RoundingTolerance("2"), 0.4);
  EXPECT_DOUBLE_EQ(RoundingTolerance("1.5e-3"), 4e-5);
}

// The API's figure for an edit's points is the planner's limit (it once said 20 million
// while the planner refused past 4 million).
TEST(ProtoDefaults, TheEditPointLimitIsThePlanners) {
  const Descriptor* edit = DocumentedPool().FindMessageTypeByName("strata.v1.MapEdit");
  ASSERT_NE(edit, nullptr);
  google::protobuf::SourceLocation location;
  ASSERT_TRUE(edit->FindFieldByName("add_obstacle")->GetSourceLocation(&location));
  std::smatch match;
  static const std::regex kLimit(R"(at most\s+([0-9,]+)\s+points)");
  ASSERT_TRUE(std::regex_search(location.leading_comments, match, kLimit))
      << location.leading_comments;
  std::string digits = match[1];
  std::erase(digits, ',');
  EXPECT_EQ(std::stoull(digits), kMaxEditPoints);
}

}  // namespace
}  // namespace strata::server
