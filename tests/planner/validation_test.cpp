// Every Validate() blames the field at fault by its path in the planner's structs
// (Error::field), and the message names the same path: the server maps these paths to request
// fields without reading messages (server/rpc/proto_convert.hpp).
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/terrain_config.hpp"
#include "strata/planner.hpp"

namespace strata {
namespace {

using ::testing::StartsWith;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

void ExpectBlames(const Status& status, ErrorCode code, const std::string& field) {
  ASSERT_FALSE(status.ok()) << field;
  EXPECT_EQ(status.error().code, code) << field;
  EXPECT_EQ(status.error().field, field);
  EXPECT_THAT(status.error().message, StartsWith(field));
}

PlanRequest ValidRequest() {
  PlanRequest request;
  request.profile = BuiltinProfile("differential").value();
  return request;
}

TEST(PlanRequestValidate, DefaultsAndBuiltinsAreValid) {
  EXPECT_TRUE(ValidRequest().Validate().ok());
  PlanRequest biped = ValidRequest();
  biped.profile = BuiltinProfile("biped").value();
  EXPECT_TRUE(biped.Validate().ok());
}

TEST(PlanRequestValidate, BlamesEveryProfileField) {
  const struct {
    std::string field;
    std::function<void(RobotProfile*)> edit;
  } cases[] = {
      {"footprint_radius_m", [](RobotProfile* p) { p->footprint_radius_m = 0; }},
      {"max_tilt_rad", [](RobotProfile* p) { p->max_tilt_rad = 2.0; }},
      {"max_step_m", [](RobotProfile* p) { p->max_step_m = -0.1; }},
      {"reference_height_m", [](RobotProfile* p) { p->reference_height_m = kNan; }},
      {"reference_height_m", [](RobotProfile* p) { p->reference_height_m = 1.0; }},
      {"max_speed_horizontal_mps", [](RobotProfile* p) { p->max_speed_horizontal_mps = 0; }},
      {"max_speed_vertical_mps", [](RobotProfile* p) { p->max_speed_vertical_mps = -1; }},
      {"max_accel_horizontal_mps2", [](RobotProfile* p) { p->max_accel_horizontal_mps2 = kNan; }},
      {"max_accel_vertical_mps2", [](RobotProfile* p) { p->max_accel_vertical_mps2 = 0; }},
      {"headroom_m", [](RobotProfile* p) { p->headroom_m = -0.01; }},
      {"body_height_m", [](RobotProfile* p) { p->body_height_m = 0; }},
      {"body_height_min_m",
       [](RobotProfile* p) {
         p->active_height = true;
         p->body_height_min_m = kNan;
       }},
      {"body_height_max_m",
       [](RobotProfile* p) {
         p->active_height = true;
         p->body_height_max_m = 0.4;
       }},
      {"body_height_m",
       [](RobotProfile* p) {
         p->active_height = true;
         p->body_height_max_m = 0.8;
         p->body_height_m = 0.9;
       }},
  };
  for (const auto& c : cases) {
    PlanRequest request = ValidRequest();
    c.edit(&request.profile);
    ExpectBlames(request.Validate(), ErrorCode::kInvalidConfig, "profile." + c.field);
    ExpectBlames(request.profile.Validate(), ErrorCode::kInvalidConfig, "profile." + c.field);
  }
}

TEST(PlanRequestValidate, BlamesEveryOptionByItsNestedPath) {
  const struct {
    std::string field;
    std::function<void(PlanOptions*)> edit;
  } cases[] = {
      {"options.time_budget_s", [](PlanOptions* o) { o->time_budget_s = 0; }},
      {"options.snap_tolerance_m", [](PlanOptions* o) { o->snap_tolerance_m = -1; }},
      {"options.max_attempts", [](PlanOptions* o) { o->max_attempts = 0; }},
      {"options.max_attempts", [](PlanOptions* o) { o->max_attempts = 11; }},
      {"options.search.max_expansions", [](PlanOptions* o) { o->search.max_expansions = 0; }},
      {"options.search.rim_margin_m", [](PlanOptions* o) { o->search.rim_margin_m = kNan; }},
      {"options.optimizer.weights.smoothness",
       [](PlanOptions* o) { o->optimizer.weights.smoothness = -1; }},
      {"options.optimizer.weights.time", [](PlanOptions* o) { o->optimizer.weights.time = kNan; }},
      {"options.optimizer.weights.safety",
       [](PlanOptions* o) { o->optimizer.weights.safety = -1; }},
      {"options.optimizer.weights.edge", [](PlanOptions* o) { o->optimizer.weights.edge = -1; }},
      {"options.optimizer.weights.ground",
       [](PlanOptions* o) { o->optimizer.weights.ground = -1; }},
      {"options.optimizer.weights.feasibility",
       [](PlanOptions* o) { o->optimizer.weights.feasibility = -1; }},
      {"options.optimizer.weights.height",
       [](PlanOptions* o) { o->optimizer.weights.height = -1; }},
      {"options.optimizer.weights.turning",
       [](PlanOptions* o) { o->optimizer.weights.turning = kNan; }},
      {"options.optimizer.cost.limit_margin",
       [](PlanOptions* o) { o->optimizer.cost.limit_margin = 1.5; }},
      {"options.optimizer.cost.samples_per_piece",
       [](PlanOptions* o) { o->optimizer.cost.samples_per_piece = 1; }},
      {"options.optimizer.piece_length_m", [](PlanOptions* o) { o->optimizer.piece_length_m = 0; }},
      {"options.verifier.limit_tolerance",
       [](PlanOptions* o) { o->verifier.limit_tolerance = -1; }},
  };
  for (const auto& c : cases) {
    PlanRequest request = ValidRequest();
    c.edit(&request.options);
    ExpectBlames(request.Validate(), ErrorCode::kInvalidConfig, c.field);
  }
  // Validated alone, a stage's settings are blamed under the stage's own name.
  SearchConfig search;
  search.max_expansions = 0;
  ExpectBlames(search.Validate(), ErrorCode::kInvalidConfig, "search.max_expansions");
  OptimizerConfig optimizer;
  optimizer.weights.safety = -1;
  ExpectBlames(optimizer.Validate(), ErrorCode::kInvalidConfig, "optimizer.weights.safety");
}

TEST(PlanRequestValidate, BlamesTheNonFiniteComponentOfStartAndGoal) {
  for (const std::string state : {"start", "goal"}) {
    for (const std::string vector : {"position_m", "velocity_mps", "acceleration_mps2"}) {
      for (int axis = 0; axis < 3; ++axis) {
        PlanRequest request = ValidRequest();
        RobotState& s = state == "start" ? request.start : request.goal;
        Eigen::Vector3d& v = vector == "position_m"     ? s.position_m
                             : vector == "velocity_mps" ? s.velocity_mps
                                                        : s.acceleration_mps2;
        v(axis) = axis == 1 ? std::numeric_limits<double>::infinity() : kNan;
        ExpectBlames(request.Validate(), ErrorCode::kInvalidInput,
                     state + "." + vector + "." + "xyz"[axis]);
      }
    }
  }
}

TEST(AssessmentConfigValidate, BlamesEveryStageFieldByItsPath) {
  const struct {
    std::string field;
    std::function<void(AssessmentConfig*)> edit;
  } cases[] = {
      {"ground.radius_m", [](AssessmentConfig* c) { c->ground.radius_m = -1; }},
      {"ground.max_tilt_rad", [](AssessmentConfig* c) { c->ground.max_tilt_rad = 2.0; }},
      {"ground.height_tolerance_m", [](AssessmentConfig* c) { c->ground.height_tolerance_m = 1; }},
      {"grid.resolution_m", [](AssessmentConfig* c) { c->grid.resolution_m = kNan; }},
      {"grid.padding_m", [](AssessmentConfig* c) { c->grid.padding_m = -1; }},
      {"grid.band_height_m", [](AssessmentConfig* c) { c->grid.band_height_m = 0; }},
      {"grid.distance_cap_m", [](AssessmentConfig* c) { c->grid.distance_cap_m = 40; }},
      {"grid.max_columns", [](AssessmentConfig* c) { c->grid.max_columns = 0; }},
      {"field.plane_ransac_iterations",
       [](AssessmentConfig* c) { c->field.plane_ransac_iterations = 0; }},
      {"field.diffusion_distance_m",
       [](AssessmentConfig* c) { c->field.diffusion_distance_m = -1; }},
      {"num_threads", [](AssessmentConfig* c) { c->num_threads = -3; }},
  };
  EXPECT_TRUE(AssessmentConfig{}.Validate().ok());
  for (const auto& c : cases) {
    AssessmentConfig config;
    c.edit(&config);
    ExpectBlames(config.Validate(), ErrorCode::kInvalidConfig, c.field);
  }
}

TEST(TraversabilityParamsValidate, BlamesItsFields) {
  TraversabilityParams params;
  params.max_step_m = -1;
  ExpectBlames(params.Validate(), ErrorCode::kInvalidConfig, "traversability.max_step_m");
}

}  // namespace
}  // namespace strata
