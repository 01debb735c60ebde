// Conversions between strata.v1 messages and planner types: round trips, defaults, and the
// request field each validation error blames.
#include "rpc/proto_convert.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "common/packed_points.hpp"
#include "rpc/planner_service.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::string FieldOf(const ServiceError& error) {
  return error.field_violations.empty() ? "" : error.field_violations[0].field;
}

Trajectory RandomTrajectory(int dimension, int pieces, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-2.0, 2.0);
  Trajectory trajectory;
  trajectory.dimension = dimension;
  for (int i = 0; i < pieces; ++i) {
    TrajectoryPiece piece;
    piece.duration_s = 0.5 + 0.25 * i;
    piece.coefficients.resize(6, dimension);
    for (int k = 0; k < 6; ++k) {
      for (int a = 0; a < dimension; ++a) piece.coefficients(k, a) = value(rng);
    }
    trajectory.pieces.push_back(piece);
  }
  return trajectory;
}

// Evaluates the message exactly as trajectory.proto documents it.
double EvaluateMessage(const v1::Trajectory& message, double t, int axis) {
  int i = 0;
  while (i + 1 < message.pieces_size() && t > message.pieces(i).duration_s()) {
    t -= message.pieces(i).duration_s();
    ++i;
  }
  double value = 0;
  const auto& c = message.pieces(i).axes(axis).coefficients();
  for (int k = 0; k < c.size(); ++k) value += c[k] * std::pow(t, k);
  return value;
}

TEST(ProtoConvertTest, TrajectoryRoundTripsAndMeansWhatTheProtoSays) {
  for (const int dimension : {3, 4}) {
    const Trajectory original = RandomTrajectory(dimension, 3, 7u + dimension);
    v1::Trajectory message;
    ToProto(original, &message);
    EXPECT_EQ(message.frame(), "map");
    EXPECT_EQ(message.dimension(), dimension);
    EXPECT_DOUBLE_EQ(message.duration_s(), original.TotalDuration());
    Result<Trajectory> back = FromProto(message);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->pieces.size(), original.pieces.size());
    for (std::size_t i = 0; i < original.pieces.size(); ++i) {
      EXPECT_EQ(back->pieces[i].duration_s, original.pieces[i].duration_s);
      EXPECT_EQ(back->pieces[i].coefficients, original.pieces[i].coefficients);
    }
    for (double t = 0; t <= original.TotalDuration(); t += 0.1) {
      const Eigen::VectorXd p = original.Position(t);
      for (int a = 0; a < dimension; ++a) {
        EXPECT_NEAR(EvaluateMessage(message, t, a), p(a), 1e-9) << "t=" << t << " axis " << a;
      }
    }
  }
}

TEST(ProtoConvertTest, MalformedTrajectoriesNameTheField) {
  v1::Trajectory message;
  ToProto(RandomTrajectory(3, 2, 1), &message);
  message.mutable_pieces(1)->set_duration_s(0);
  EXPECT_EQ(FieldOf(FromProto(message).error()), "pieces[1].duration_s");
  message.Clear();
  ToProto(RandomTrajectory(3, 2, 1), &message);
  message.mutable_pieces(0)->mutable_axes(2)->add_coefficients(1);
  EXPECT_EQ(FieldOf(FromProto(message).error()), "pieces[0].axes[2].coefficients");
}

// A warm start arrives as the trajectory a Plan returned (fields blamed under
// warm_start.trajectory), with elapsed_s when set and -1 (the nearest point) when not.
TEST(ProtoConvertTest, WarmStartsArriveAsTheTrajectoryAndBlameTheirFields) {
  v1::WarmStart message;
  const Trajectory original = RandomTrajectory(3, 4, 11);
  ToProto(original, message.mutable_trajectory());
  Result<WarmStart> unset = WarmStartFromRequest(message);
  ASSERT_TRUE(unset.ok()) << unset.error().message;
  EXPECT_EQ(unset->elapsed_s, -1);
  ASSERT_EQ(unset->trajectory.pieces.size(), original.pieces.size());
  EXPECT_EQ(unset->trajectory.pieces[2].coefficients, original.pieces[2].coefficients);
  message.set_elapsed_s(1.5);
  EXPECT_EQ(WarmStartFromRequest(message)->elapsed_s, 1.5);
  message.set_elapsed_s(-1);
  EXPECT_EQ(FieldOf(WarmStartFromRequest(message).error()), "warm_start.elapsed_s");
  message.set_elapsed_s(std::nan(""));
  EXPECT_EQ(FieldOf(WarmStartFromRequest(message).error()), "warm_start.elapsed_s");
  message.clear_elapsed_s();
  message.mutable_trajectory()->mutable_pieces(3)->set_duration_s(-2);
  EXPECT_EQ(FieldOf(WarmStartFromRequest(message).error()),
            "warm_start.trajectory.pieces[3].duration_s");
  message.mutable_trajectory()->clear_pieces();
  EXPECT_EQ(FieldOf(WarmStartFromRequest(message).error()), "warm_start.trajectory.pieces");
}

// The plan's figures reach the response, the new ones included.
TEST(ProtoConvertTest, PlanStatsArriveWhole) {
  PlanStats stats;
  stats.length_m = 12.5;
  stats.time_stretch = 1.02;
  stats.warm_started = true;
  stats.fallback = true;
  stats.fallback_reason = "horizontal acceleration 1.03 m/s^2 exceeds the bound";
  stats.limiting_bound = "vertical_speed";
  stats.limiting_bound_fraction = 0.97;
  v1::PlanStats message;
  ToProto(stats, &message);
  EXPECT_EQ(message.length_m(), 12.5);
  EXPECT_EQ(message.time_stretch(), 1.02);
  EXPECT_TRUE(message.warm_started());
  EXPECT_TRUE(message.fallback());
  EXPECT_EQ(message.fallback_reason(), stats.fallback_reason);
  EXPECT_EQ(message.limiting_bound(), "vertical_speed");
  EXPECT_EQ(message.limiting_bound_fraction(), 0.97);
  // No ceiling over the trajectory: the headroom is absent, never "Infinity" in JSON.
  stats.min_headroom_m = std::numeric_limits<double>::infinity();
  message.Clear();
  ToProto(stats, &message);
  EXPECT_FALSE(message.has_min_headroom_m());
  std::string json;
  ASSERT_TRUE(google::protobuf::util::MessageToJsonString(message, &json).ok());
  EXPECT_THAT(json, Not(HasSubstr("Infinity")));
  stats.min_headroom_m = 0.25;
  ToProto(stats, &message);
  EXPECT_EQ(message.min_headroom_m(), 0.25);
}

TEST(ProtoConvertTest, TerrainParametersDefaultAndBlameTheirField) {
  const AssessmentConfig defaults;
  Result<AssessmentConfig> unset = FromProto(v1::TerrainParameters(), "terrain");
  ASSERT_TRUE(unset.ok());
  EXPECT_EQ(unset->grid.resolution_m, defaults.grid.resolution_m);
  EXPECT_EQ(unset->ground.radius_m, defaults.ground.radius_m);

  v1::TerrainParameters terrain;
  terrain.set_resolution_m(0.3);
  terrain.set_max_tilt_rad(0.3);
  Result<AssessmentConfig> set = FromProto(terrain, "terrain");
  ASSERT_TRUE(set.ok());
  EXPECT_EQ(set->grid.resolution_m, 0.3);
  EXPECT_EQ(set->ground.max_tilt_rad, 0.3);
  v1::TerrainParameters shown;
  ToProto(set.value(), &shown);
  EXPECT_EQ(shown.resolution_m(), 0.3);
  EXPECT_TRUE(shown.has_padding_m());

  terrain.set_ground_radius_m(std::numeric_limits<double>::quiet_NaN());
  Result<AssessmentConfig> bad = FromProto(terrain, "terrain");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(FieldOf(bad.error()), "terrain.ground_radius_m");
  EXPECT_THAT(bad.error().message, ::testing::StartsWith("ground.radius_m = nan"));
  EXPECT_EQ(std::get<ErrorCode>(bad.error().code), ErrorCode::kInvalidConfig);
}

// Every field of TerrainParameters, set out of range alone, is blamed by its request path
// (through the one table that maps the planner's per-stage names to the flat proto names).
TEST(ProtoConvertTest, EveryTerrainFieldIsBlamedByItsRequestPath) {
  const google::protobuf::Descriptor* descriptor = v1::TerrainParameters::descriptor();
  ASSERT_GT(descriptor->field_count(), 0);
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* field = descriptor->field(i);
    ASSERT_EQ(field->cpp_type(), google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE);
    v1::TerrainParameters terrain;
    terrain.GetReflection()->SetDouble(&terrain, field, std::nan(""));
    Result<AssessmentConfig> bad = FromProto(terrain, "header.terrain");
    ASSERT_FALSE(bad.ok()) << field->name();
    EXPECT_EQ(FieldOf(bad.error()), "header.terrain." + field->name());
  }
  // A stage parameter the request cannot set blames the message as a whole.
  EXPECT_EQ(TerrainRequestField("field.weight_tilt", "terrain"), "terrain");
}

TEST(ProtoConvertTest, ProfilesByNameOrInlineOverTheDefaults) {
  v1::PlanRequest request;
  request.set_profile_name("biped");
  Result<RobotProfile> biped = ProfileFromRequest(request);
  ASSERT_TRUE(biped.ok());
  EXPECT_TRUE(biped->active_height);

  request.set_profile_name("tank");
  Result<RobotProfile> unknown = ProfileFromRequest(request);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(FieldOf(unknown.error()), "profile_name");
  EXPECT_THAT(unknown.error().message, HasSubstr("differential"));

  request.mutable_profile()->set_max_speed_horizontal_mps(0.5);
  Result<RobotProfile> custom = ProfileFromRequest(request);
  ASSERT_TRUE(custom.ok()) << custom.error().message;
  EXPECT_EQ(custom->max_speed_horizontal_mps, 0.5);
  EXPECT_EQ(custom->footprint_radius_m, RobotProfile().footprint_radius_m);
  v1::RobotProfile shown;
  ToProto(custom.value(), &shown);
  EXPECT_EQ(shown.max_speed_horizontal_mps(), 0.5);
  EXPECT_TRUE(shown.has_headroom_m());

  request.mutable_profile()->set_max_speed_horizontal_mps(-1);
  Result<RobotProfile> bad = ProfileFromRequest(request);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(FieldOf(bad.error()), "profile.max_speed_horizontal_mps");

  Result<RobotProfile> missing = ProfileFromRequest(v1::PlanRequest());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(FieldOf(missing.error()), "profile_name");
}

v1::PlanRequest ValidRequest() {
  v1::PlanRequest request;
  request.set_map_id("demo");
  request.set_profile_name("differential");
  request.mutable_start()->mutable_position_m()->set_x(1);
  request.mutable_goal()->mutable_position_m()->set_x(2);
  return request;
}

TEST(ProtoConvertTest, PlanRequestsBlameTheExactField) {
  ASSERT_TRUE(ParsePlanRequest(ValidRequest()).ok());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::function<void(v1::PlanRequest*)> edit;
    std::string field;
  } cases[] = {
      {[](v1::PlanRequest* r) { r->clear_map_id(); }, "map_id"},
      {[](v1::PlanRequest* r) { r->clear_start(); }, "start"},
      {[](v1::PlanRequest* r) { r->mutable_goal()->clear_position_m(); }, "goal.position_m"},
      {[&](v1::PlanRequest* r) { r->mutable_start()->mutable_position_m()->set_x(nan); },
       "start.position_m.x"},
      {[&](v1::PlanRequest* r) { r->mutable_goal()->mutable_velocity_mps()->set_y(inf); },
       "goal.velocity_mps.y"},
      {[&](v1::PlanRequest* r) { r->mutable_start()->mutable_acceleration_mps2()->set_z(-inf); },
       "start.acceleration_mps2.z"},
      {[](v1::PlanRequest* r) { r->mutable_options()->set_time_budget_s(0); },
       "options.time_budget_s"},
      {[](v1::PlanRequest* r) { r->mutable_options()->mutable_weights()->set_safety(-1); },
       "options.weights.safety"},
      {[](v1::PlanRequest* r) { r->mutable_options()->set_max_attempts(0); },
       "options.max_attempts"},
      {[](v1::PlanRequest* r) { r->mutable_options()->set_sample_dt_s(0); }, "options.sample_dt_s"},
  };
  for (const Case& c : cases) {
    v1::PlanRequest request = ValidRequest();
    c.edit(&request);
    Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
    ASSERT_FALSE(parsed.ok()) << c.field;
    EXPECT_EQ(FieldOf(parsed.error()), c.field);
  }
}

std::string ParseFailureField(const v1::PlanRequest& request) {
  Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
  return parsed.ok() ? "(accepted)" : FieldOf(parsed.error());
}

// The planner's path of a profile field is its path in PlanRequest, by design: each field of
// v1::RobotProfile, set out of range inline, is blamed as "profile.<name>" by the server, and
// RobotProfile::Validate's message names the same path.
TEST(ProtoConvertTest, EveryProfileFieldHasTheSamePathInThePlannerAndTheRequest) {
  const google::protobuf::Descriptor* descriptor = v1::RobotProfile::descriptor();
  int checked = 0;
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* field = descriptor->field(i);
    if (field->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) continue;
    v1::PlanRequest request = ValidRequest();
    v1::RobotProfile* profile = request.mutable_profile();
    profile->set_active_height(true);  // Else the body height range is not checked.
    profile->GetReflection()->SetDouble(profile, field, std::nan(""));
    const std::string path = "profile." + field->name();
    Result<RobotProfile> bad = ProfileFromRequest(request);
    ASSERT_FALSE(bad.ok()) << path;
    EXPECT_EQ(FieldOf(bad.error()), path);
    // The message is the planner's own (RobotProfile::Validate), naming its path: the same.
    EXPECT_THAT(bad.error().message, ::testing::StartsWith(path + " = nan"));
    EXPECT_EQ(ParseFailureField(request), path);
    ++checked;
  }
  EXPECT_EQ(checked, 12);
}

TEST(ProtoConvertTest, EveryOptionIsBlamedByItsRequestPath) {
  const google::protobuf::Descriptor* weights = v1::CostWeights::descriptor();
  for (int i = 0; i < weights->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* field = weights->field(i);
    v1::PlanRequest request = ValidRequest();
    v1::CostWeights* w = request.mutable_options()->mutable_weights();
    w->GetReflection()->SetDouble(w, field, -1);
    // The planner blames "options.optimizer.weights.<name>"; the one rename table maps it.
    EXPECT_EQ(ParseFailureField(request), "options.weights." + field->name());
  }
  const struct {
    std::function<void(v1::PlanOptions*)> edit;
    std::string field;
  } cases[] = {
      {[](v1::PlanOptions* o) { o->set_time_budget_s(0); }, "options.time_budget_s"},
      {[](v1::PlanOptions* o) { o->set_time_budget_s(std::nan("")); }, "options.time_budget_s"},
      {[](v1::PlanOptions* o) { o->set_snap_tolerance_m(-1); }, "options.snap_tolerance_m"},
      {[](v1::PlanOptions* o) { o->set_max_attempts(0); }, "options.max_attempts"},
      {[](v1::PlanOptions* o) { o->set_max_attempts(11); }, "options.max_attempts"},
      {[](v1::PlanOptions* o) { o->set_sample_dt_s(-1); }, "options.sample_dt_s"},
      // The planner blames "options.optimizer.cost.safety_threshold".
      {[](v1::PlanOptions* o) { o->set_safety_threshold(-0.5); }, "options.safety_threshold"},
      {[](v1::PlanOptions* o) { o->set_safety_threshold(std::nan("")); },
       "options.safety_threshold"},
      // ... and "options.search.rim_weight".
      {[](v1::PlanOptions* o) { o->set_rim_weight(-1); }, "options.rim_weight"},
  };
  for (const auto& c : cases) {
    v1::PlanRequest request = ValidRequest();
    c.edit(request.mutable_options());
    EXPECT_EQ(ParseFailureField(request), c.field);
  }
  v1::PlanRequest ten = ValidRequest();
  ten.mutable_options()->set_max_attempts(10);
  EXPECT_EQ(ParseFailureField(ten), "(accepted)");
}

TEST(ProtoConvertTest, EveryStartAndGoalComponentIsBlamedByItsPath) {
  for (const std::string state : {"start", "goal"}) {
    for (const std::string vector : {"position_m", "velocity_mps", "acceleration_mps2"}) {
      for (const std::string axis : {"x", "y", "z"}) {
        v1::PlanRequest request = ValidRequest();
        v1::RobotState* s = state == "start" ? request.mutable_start() : request.mutable_goal();
        google::protobuf::Message* v =
            s->GetReflection()->MutableMessage(s, s->GetDescriptor()->FindFieldByName(vector));
        v->GetReflection()->SetDouble(v, v->GetDescriptor()->FindFieldByName(axis),
                                      std::numeric_limits<double>::infinity());
        EXPECT_EQ(ParseFailureField(request), state + "." + vector + "." + axis);
      }
    }
  }
}

// A keep-out zone around (x, y) with corners 1 m apart, over the floor's storey.
void AddZone(v1::PlanRequest* request, double x, double y) {
  v1::Prism* zone = request->add_keep_out();
  for (const auto& [dx, dy] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
    v1::Vector2* corner = zone->add_polygon_m();
    corner->set_x(x + dx);
    corner->set_y(y + dy);
  }
  zone->set_z_min_m(-0.5);
  zone->set_z_max_m(2.5);
}

TEST(ProtoConvertTest, KeepOutZonesArriveAsGivenAndRoundTrip) {
  v1::PlanRequest request = ValidRequest();
  AddZone(&request, 3, 4);
  AddZone(&request, 7, 8);
  Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  ASSERT_EQ(parsed->plan.keep_out.size(), 2u);
  const Prism& zone = parsed->plan.keep_out[1];
  ASSERT_EQ(zone.polygon_m.size(), 4u);
  EXPECT_EQ(zone.polygon_m[2], Eigen::Vector2d(8, 9));
  EXPECT_EQ(zone.z_min_m, -0.5);
  EXPECT_EQ(zone.z_max_m, 2.5);
  v1::Prism back;
  ToProto(zone, &back);
  EXPECT_EQ(back.SerializeAsString(), request.keep_out(1).SerializeAsString());
}

TEST(ProtoConvertTest, MalformedKeepOutZonesAreBlamedByTheirRequestPath) {
  v1::PlanRequest request = ValidRequest();
  AddZone(&request, 3, 4);
  AddZone(&request, 7, 8);
  request.mutable_keep_out(1)->mutable_polygon_m(2)->set_x(
      std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(ParseFailureField(request), "keep_out[1].polygon_m[2].x");

  request = ValidRequest();
  AddZone(&request, 3, 4);
  request.mutable_keep_out(0)->clear_z_max_m();
  EXPECT_EQ(ParseFailureField(request), "keep_out[0].z_max_m");

  request = ValidRequest();
  AddZone(&request, 3, 4);
  request.mutable_keep_out(0)->mutable_polygon_m()->DeleteSubrange(2, 2);
  EXPECT_EQ(ParseFailureField(request), "keep_out[0].polygon_m");

  request = ValidRequest();
  for (int i = 0; i <= kMaxRequestKeepOutZones; ++i) AddZone(&request, i, 0);
  EXPECT_EQ(ParseFailureField(request), "keep_out");
}

// UpdateMap's edits arrive in order, keep-out zones apart; a request with no edit, more
// than kMaxMapEdits, an edit of no kind or a bad prism is blamed by its field.
TEST(ProtoConvertTest, MapEditsArriveInOrderAndBadOnesAreBlamedByTheirPath) {
  v1::PlanRequest zones;  // Prisms to copy.
  AddZone(&zones, 3, 4);
  AddZone(&zones, 7, 8);
  v1::UpdateMapRequest request;
  request.set_map_id("site");
  *request.add_edits()->mutable_remove_points() = zones.keep_out(0);
  *request.add_edits()->mutable_add_keep_out() = zones.keep_out(1);
  *request.add_edits()->mutable_add_obstacle() = zones.keep_out(1);
  Result<ParsedMapEdits> parsed = MapEditsFromProto(request);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  ASSERT_EQ(parsed->edits.size(), 2u);
  EXPECT_EQ(parsed->edits[0].kind, MapEdit::Kind::kRemovePoints);
  EXPECT_EQ(parsed->edits[0].region.polygon_m[0], Eigen::Vector2d(3, 4));
  EXPECT_EQ(parsed->edits[1].kind, MapEdit::Kind::kAddObstacle);
  EXPECT_EQ(parsed->edits[1].region.polygon_m[0], Eigen::Vector2d(7, 8));
  ASSERT_EQ(parsed->add_keep_out.size(), 1u);
  EXPECT_EQ(parsed->add_keep_out[0].polygon_m[0], Eigen::Vector2d(7, 8));

  const auto field_of = [](const v1::UpdateMapRequest& edited) {
    Result<ParsedMapEdits> result = MapEditsFromProto(edited);
    return result.ok() ? std::string("(accepted)") : FieldOf(result.error());
  };
  v1::UpdateMapRequest empty;
  empty.set_map_id("site");
  EXPECT_EQ(field_of(empty), "edits");
  empty.set_clear_keep_out(true);  // Clearing the zones alone is an edit.
  EXPECT_EQ(field_of(empty), "(accepted)");

  v1::UpdateMapRequest too_many;
  too_many.set_map_id("site");
  for (int i = 0; i < kMaxMapEdits; ++i) {
    *too_many.add_edits()->mutable_add_keep_out() = zones.keep_out(0);
  }
  EXPECT_EQ(field_of(too_many), "(accepted)");
  *too_many.add_edits()->mutable_add_keep_out() = zones.keep_out(0);
  EXPECT_EQ(field_of(too_many), "edits");

  v1::UpdateMapRequest unset = request;
  unset.mutable_edits(1)->clear_kind();
  EXPECT_EQ(field_of(unset), "edits[1]");
  EXPECT_THAT(MapEditsFromProto(unset).error().message,
              HasSubstr("set add_obstacle, remove_points, add_keep_out or scan"));

  v1::UpdateMapRequest bad_prism = request;
  bad_prism.mutable_edits(2)->mutable_add_obstacle()->clear_z_max_m();
  EXPECT_EQ(field_of(bad_prism), "edits[2].add_obstacle.z_max_m");

  // Checked whole here, before any queue: a keep-out zone is kept in the map and read by every
  // plan on it (request_fuzzer found these passing).
  v1::UpdateMapRequest crossed = request;
  v1::Prism* zone = crossed.mutable_edits(1)->mutable_add_keep_out();
  std::swap(*zone->mutable_polygon_m(1), *zone->mutable_polygon_m(2));  // A bow tie.
  EXPECT_EQ(field_of(crossed), "edits[1].add_keep_out.polygon_m");
  v1::UpdateMapRequest not_finite = request;
  not_finite.mutable_edits(2)->mutable_add_obstacle()->mutable_polygon_m(0)->set_x(
      std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(field_of(not_finite), "edits[2].add_obstacle.polygon_m[0].x");

  v1::UpdateMapRequest no_id = request;
  no_id.clear_map_id();
  EXPECT_EQ(field_of(no_id), "map_id");
}

// A scan's points arrive as packed little-endian float32 x, y, z, bit for bit, with its region
// and in its place among the edits; points that are not whole 12-byte triples or not finite
// are refused naming edits[i].scan.points (a NaN's index in the message), more than
// kMaxEditPoints as RESOURCE_EXHAUSTED, and a bad region by its path.
TEST(ProtoConvertTest, AScanArrivesBitForBitAndBadPointsAreBlamedByTheirPath) {
  v1::PlanRequest zones;  // Prisms to copy.
  AddZone(&zones, 3, 4);
  const PointCloud points = {{3.25f, 4.5f, 0.1f}, {1.0f / 3, -0.0f, 1e-30f}, {-7.0f, 1e6f, 2.0f}};
  std::string bytes;
  for (const Eigen::Vector3f& p : points) AppendPackedPoint(p, &bytes);
  ASSERT_EQ(bytes.size(), 36u);
  // Little-endian, whatever the machine: 3.25f is 0x40500000.
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x00\x00\x50\x40", 4));
  v1::UpdateMapRequest request;
  request.set_map_id("site");
  *request.add_edits()->mutable_add_obstacle() = zones.keep_out(0);
  v1::Scan* scan = request.add_edits()->mutable_scan();
  *scan->mutable_region() = zones.keep_out(0);
  scan->set_points(bytes);
  request.add_edits()->mutable_scan()->mutable_region()->CopyFrom(zones.keep_out(0));  // Empty.
  Result<ParsedMapEdits> parsed = MapEditsFromProto(request);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  ASSERT_EQ(parsed->edits.size(), 3u);
  EXPECT_EQ(parsed->edits[0].kind, MapEdit::Kind::kAddObstacle);
  EXPECT_EQ(parsed->edits[0].points, nullptr);
  EXPECT_EQ(parsed->edits[1].kind, MapEdit::Kind::kScan);
  EXPECT_EQ(parsed->edits[1].region.polygon_m[0], Eigen::Vector2d(3, 4));
  EXPECT_EQ(parsed->edits[1].region.z_max_m, 2.5);
  ASSERT_NE(parsed->edits[1].points, nullptr);
  ASSERT_EQ(parsed->edits[1].points->size(), points.size());
  EXPECT_EQ(std::memcmp(parsed->edits[1].points->data(), points.data(), bytes.size()), 0);
  EXPECT_EQ(parsed->edits[2].kind, MapEdit::Kind::kScan);
  EXPECT_TRUE(parsed->edits[2].points == nullptr || parsed->edits[2].points->empty());
  for (const MapEdit& edit : parsed->edits) EXPECT_TRUE(edit.Validate("edit").ok());

  const auto refused = [](const v1::UpdateMapRequest& edited) {
    Result<ParsedMapEdits> result = MapEditsFromProto(edited);
    EXPECT_FALSE(result.ok());
    return result.ok() ? ServiceError{} : std::move(result).error();
  };
  v1::UpdateMapRequest ragged = request;
  ragged.mutable_edits(1)->mutable_scan()->mutable_points()->push_back('\0');
  ServiceError error = refused(ragged);
  EXPECT_EQ(error.code, ServiceError::Code(ErrorCode::kInvalidInput));
  EXPECT_EQ(FieldOf(error), "edits[1].scan.points");
  EXPECT_THAT(error.message, HasSubstr("37 bytes, not a whole number of 12-byte points"));

  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    PointCloud with_bad = points;
    with_bad[2].y() = bad;
    std::string bad_bytes;
    for (const Eigen::Vector3f& p : with_bad) AppendPackedPoint(p, &bad_bytes);
    v1::UpdateMapRequest not_finite = request;
    not_finite.mutable_edits(1)->mutable_scan()->set_points(bad_bytes);
    error = refused(not_finite);
    EXPECT_EQ(error.code, ServiceError::Code(ErrorCode::kInvalidInput));
    EXPECT_EQ(FieldOf(error), "edits[1].scan.points");
    EXPECT_THAT(error.message, HasSubstr("not finite at index 2"));
  }

  v1::UpdateMapRequest too_many = request;
  too_many.mutable_edits(1)->mutable_scan()->set_points(
      std::string((kMaxEditPoints + 1) * kPackedPointBytes, '\0'));
  error = refused(too_many);
  EXPECT_EQ(error.code, ServiceError::Code(ErrorCode::kResourceExhausted));
  EXPECT_EQ(FieldOf(error), "edits[1].scan.points");
  EXPECT_THAT(error.message, HasSubstr("4000001 points"));

  v1::UpdateMapRequest no_region = request;
  no_region.mutable_edits(1)->mutable_scan()->clear_region();
  EXPECT_EQ(FieldOf(refused(no_region)), "edits[1].scan.region.z_min_m");
  v1::UpdateMapRequest flat = request;
  flat.mutable_edits(1)->mutable_scan()->mutable_region()->mutable_polygon_m()->DeleteSubrange(2,
                                                                                               2);
  EXPECT_EQ(FieldOf(refused(flat)), "edits[1].scan.region.polygon_m");
}

// Vias arrive in order with their stop flag; a missing, non-finite or one-too-many via is
// refused as INVALID_INPUT (INVALID_ARGUMENT) naming its field.
TEST(ProtoConvertTest, ViasArriveInOrderAndBadOnesAreBlamedByTheirPath) {
  const auto add_via = [](v1::PlanRequest* request, double x, bool stop) {
    v1::Via* via = request->add_via();
    via->mutable_position_m()->set_x(x);
    via->mutable_position_m()->set_y(2);
    via->mutable_position_m()->set_z(0.3);
    via->set_stop(stop);
  };
  v1::PlanRequest request = ValidRequest();
  add_via(&request, 3, false);
  add_via(&request, 4, true);
  Result<ParsedPlanRequest> parsed = ParsePlanRequest(request);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  ASSERT_EQ(parsed->plan.via.size(), 2u);
  EXPECT_EQ(parsed->plan.via[0].position_m, Eigen::Vector3d(3, 2, 0.3));
  EXPECT_FALSE(parsed->plan.via[0].stop);
  EXPECT_EQ(parsed->plan.via[1].position_m, Eigen::Vector3d(4, 2, 0.3));
  EXPECT_TRUE(parsed->plan.via[1].stop);

  for (const std::string axis : {"x", "y", "z"}) {
    v1::PlanRequest bad = request;
    v1::Vector3* p = bad.mutable_via(1)->mutable_position_m();
    p->GetReflection()->SetDouble(p, p->GetDescriptor()->FindFieldByName(axis),
                                  std::numeric_limits<double>::quiet_NaN());
    EXPECT_EQ(ParseFailureField(bad), "via[1].position_m." + axis);
    const Result<ParsedPlanRequest> refused = ParsePlanRequest(bad);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ServiceError::Code(ErrorCode::kInvalidInput));
  }
  v1::PlanRequest missing = request;
  missing.mutable_via(0)->clear_position_m();
  EXPECT_EQ(ParseFailureField(missing), "via[0].position_m");

  v1::PlanRequest too_many = ValidRequest();
  for (int i = 0; i <= kMaxVias; ++i) add_via(&too_many, i, false);
  EXPECT_EQ(ParseFailureField(too_many), "via");
  const Result<ParsedPlanRequest> refused = ParsePlanRequest(too_many);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ServiceError::Code(ErrorCode::kInvalidInput));
  EXPECT_THAT(refused.error().message, HasSubstr(std::to_string(kMaxVias)));
}

// Planner errors of Plan itself (snapping, the map's assessment) reach the request field.
TEST(ProtoConvertTest, PlannerFieldPathsMapToRequestFields) {
  EXPECT_EQ(PlanRequestField("start.position_m", false), "start.position_m");
  EXPECT_EQ(PlanRequestField("goal.position_m", true), "goal.position_m");
  // A built-in profile that does not fit the map: the name chose it.
  EXPECT_EQ(PlanRequestField("profile.footprint_radius_m", false), "profile_name");
  EXPECT_EQ(PlanRequestField("profile.footprint_radius_m", true), "profile.footprint_radius_m");
  EXPECT_EQ(PlanRequestField("options.optimizer.weights.height", true), "options.weights.height");
  EXPECT_EQ(PlanRequestField("options.optimizer.cost.safety_threshold", true),
            "options.safety_threshold");
  EXPECT_EQ(PlanRequestField("options.search.rim_weight", true), "options.rim_weight");
  EXPECT_EQ(PlanRequestField("keep_out[3].polygon_m[2].y", true), "keep_out[3].polygon_m[2].y");
  EXPECT_EQ(PlanRequestField("keep_out[0].z_min_m", false), "keep_out[0].z_min_m");
  // An index on a field that is not repeated names no request field.
  EXPECT_EQ(PlanRequestField("start[0].position_m", true), "");
  // Settings a request cannot override, and errors without a field, blame no request field.
  EXPECT_EQ(PlanRequestField("options.search.max_expansions", true), "");
  EXPECT_EQ(PlanRequestField("options.optimizer.weights.edge", true), "");
  EXPECT_EQ(PlanRequestField("options.optimizer.cost.safety_fade_m", true), "");
  EXPECT_EQ(PlanRequestField("traversability.max_tilt_rad", true), "");
  EXPECT_EQ(PlanRequestField("", true), "");
}

TEST(ProtoConvertTest, OptionsRoundTripWithEveryFieldSet) {
  v1::PlanOptions message;
  message.set_time_budget_s(3.5);
  message.set_snap_tolerance_m(0.25);
  message.set_max_attempts(5);
  message.set_safety_threshold(4.5);
  message.set_rim_weight(0.25);
  v1::CostWeights* w = message.mutable_weights();
  w->set_smoothness(2);
  w->set_time(20);
  w->set_safety(3e3);
  w->set_ground(4e4);
  w->set_feasibility(5e5);
  w->set_height(6e3);
  w->set_turning(7);
  const PlanOptions options = FromProto(message);
  EXPECT_EQ(options.optimizer.weights.feasibility, 5e5);
  EXPECT_EQ(options.optimizer.weights.turning, 7);
  EXPECT_EQ(options.optimizer.cost.safety_threshold, 4.5);
  EXPECT_EQ(options.search.rim_weight, 0.25);
  v1::PlanOptions back;
  ToProto(options, &back);
  EXPECT_EQ(back.SerializeAsString(), message.SerializeAsString());
}

TEST(ProtoConvertTest, TimeBudgetIsCappedByServerAndDeadline) {
  v1::PlanRequest request = ValidRequest();
  ParsedPlanRequest parsed = ParsePlanRequest(request).value();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_DOUBLE_EQ(PlanTimeBudget(parsed, inf, 10), PlanOptions().time_budget_s);
  EXPECT_DOUBLE_EQ(PlanTimeBudget(parsed, inf, 0.5), 0.5);
  EXPECT_NEAR(PlanTimeBudget(parsed, 1.0, 10), 0.9, 1e-12);  // 10% margin ...
  EXPECT_NEAR(PlanTimeBudget(parsed, 1.5, 10), 1.4, 1e-12);  // ... at most 0.1 s.
  EXPECT_LE(PlanTimeBudget(parsed, 0.0, 10), 0.0);
  request.mutable_options()->set_time_budget_s(30);
  EXPECT_DOUBLE_EQ(PlanTimeBudget(ParsePlanRequest(request).value(), inf, 10), 10);
}

TEST(ProtoConvertTest, SamplesCoverTheTrajectoryEndToEnd) {
  const Trajectory trajectory = RandomTrajectory(4, 2, 3);  // 0.5 s + 0.75 s.
  v1::PlanResponse response;
  ASSERT_TRUE(AppendSamples(trajectory, 0.1, 1000, &response).ok());
  ASSERT_EQ(response.samples_size(), 14);  // 0, 0.1, ..., 1.2, then 1.25.
  EXPECT_DOUBLE_EQ(response.samples(13).time_s(), 1.25);
  EXPECT_TRUE(response.samples(0).has_body_height_m());
  EXPECT_NEAR(response.samples(5).position_m().y(), trajectory.Position(0.5)(1), 1e-12);
  v1::PlanResponse too_many;
  ServiceStatus refused = AppendSamples(trajectory, 1e-4, 1000, &too_many);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(FieldOf(refused.error()), "options.sample_dt_s");
}

TEST(ProtoConvertTest, FailedMapsShowTheReasonOfTheTable) {
  MapSnapshot snapshot;
  snapshot.id = "m";
  snapshot.state = MapState::kFailed;
  snapshot.stage = CreationStage::kDone;
  snapshot.failure = MakeError(ErrorCode::kMapLoadFailed, "truncated");
  snapshot.source = FileSourceInfo{"a.pcd"};
  v1::Map map;
  ToProto(snapshot, &map);
  EXPECT_EQ(map.state(), v1::MAP_STATE_FAILED);
  EXPECT_EQ(map.failure().reason(), "MAP_LOAD_FAILED");
  EXPECT_EQ(map.source().file().path(), "a.pcd");  // Never the server's own path.
}

}  // namespace
}  // namespace strata::server
