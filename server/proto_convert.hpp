#pragma once
/// Conversion between the public API's messages (strata.v1) and the planner's types: the only
/// place that knows both. Conversions from requests validate as they go and blame the
/// request field at fault by its path in the request, e.g. "start.position_m.x".
#include <string>
#include <vector>

#include "map_registry.hpp"
#include "service_error.hpp"
#include "strata/planner.hpp"
#include "strata/robot_profile.hpp"
#include "strata/terrain_config.hpp"
#include "strata/trajectory.hpp"
#include "strata/v1/map_service.pb.h"
#include "strata/v1/planner_service.pb.h"
#include "strata/v1/trajectory.pb.h"

namespace strata::server {

/// Terrain parameters over the defaults; kInvalidConfig naming `field`.<name> when a set
/// field is out of the range AssessmentConfig::Validate accepts.
Result<AssessmentConfig> FromProto(const v1::TerrainParameters& terrain, const std::string& field);
/// Every field set.
void ToProto(const AssessmentConfig& config, v1::TerrainParameters* terrain);

/// The public view of a map; `failure` gets the reason from the error table.
void ToProto(const MapSnapshot& snapshot, v1::Map* map);

/// The profile of a request: a built-in by name, or inline over the defaults. kInvalidInput
/// (unset, unknown name: "profile_name"), kInvalidConfig ("profile.<field>").
Result<RobotProfile> ProfileFromRequest(const v1::PlanRequest& request);
/// Every field set.
void ToProto(const RobotProfile& profile, v1::RobotProfile* message);

/// A start or goal; kInvalidInput for a missing position or a non-finite component
/// (blaming e.g. "start.position_m.x").
Result<RobotState> FromProto(const v1::RobotState& state, const std::string& field);

/// Options over the planner's defaults, except time_budget_s, which the caller caps (see
/// PlannerService). kInvalidConfig / kInvalidInput naming "options.<field>".
Result<PlanOptions> FromProto(const v1::PlanOptions& options);

void ToProto(const Trajectory& trajectory, v1::Trajectory* message);
/// The inverse of ToProto (clients and tests); kInvalidInput naming the field for a piece
/// with a non-positive duration or the wrong number of axes or coefficients.
Result<Trajectory> FromProto(const v1::Trajectory& message);

void ToProto(const SnapResult& snap, v1::SnappedState* message);
void ToProto(const PlanStats& stats, v1::PlanStats* message);

/// Samples every `dt_s` from 0 to the end (which is always included); kInvalidInput
/// blaming "options.sample_dt_s" when that makes more than `max_samples`.
ServiceStatus AppendSamples(const Trajectory& trajectory, double dt_s, int max_samples,
                            v1::PlanResponse* response);

}  // namespace strata::server
