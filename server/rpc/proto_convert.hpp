#pragma once
/// Conversion between the public API's messages (strata.v1) and the planner's types: every
/// message <-> planner type conversion is here. The services use both kinds of type (they
/// call the planner and answer with messages), but convert only through these functions and
/// set only fields of their own beside them (queue time, the capped time budget, page tokens).
/// Conversions from requests copy the fields that are set over the planner's defaults and call
/// the planner's Validate(), which alone holds the valid ranges; the error's field path (a path
/// in the planner's structs, Error::field) becomes the request field at fault, e.g.
/// "start.position_m.x", by PlanRequestField or TerrainRequestField. The proto's own
/// structure (presence of a required message, a oneof) is checked here.
#include <optional>
#include <string>
#include <vector>

#include "common/service_error.hpp"
#include "maps/map_registry.hpp"
#include "rpc/map_geometry.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/planner.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/trajectory.hpp"
#include "strata/prism.hpp"
#include "strata/travel_costs.hpp"
#include "strata/v1/map_service.pb.h"
#include "strata/v1/planner_service.pb.h"
#include "strata/v1/trajectory.pb.h"

namespace strata::server {

/// Terrain parameters over the defaults, validated by AssessmentConfig::Validate; its
/// kInvalidConfig blames `field`.<name> (e.g. "terrain.ground_radius_m").
Result<AssessmentConfig> FromProto(const v1::TerrainParameters& terrain, const std::string& field);
/// The request field of an AssessmentConfig field path (Error::field, e.g. "ground.radius_m")
/// for TerrainParameters at `field` ("terrain"): "terrain.ground_radius_m". The proto flattens
/// the planner's per-stage structs, so one table in proto_convert.cpp maps the names; a path
/// it does not hold (a stage parameter the request cannot set) maps to `field` itself.
std::string TerrainRequestField(const std::string& planner_field, const std::string& field);
/// Every field set.
void ToProto(const AssessmentConfig& config, v1::TerrainParameters* terrain);

/// The public view of a map; `failure` gets the reason from the error table.
void ToProto(const MapSnapshot& snapshot, v1::Map* map);

/// The edits of an UpdateMapRequest: cloud edits in order, and the keep-out zones to add.
struct ParsedMapEdits {
  std::vector<MapEdit> edits;
  std::vector<Prism> add_keep_out;
};
/// kInvalidInput blaming the request field: map_id empty, no edit (and no clear_keep_out),
/// more than kMaxMapEdits, an edit with no kind, a bad prism ("edits[2].add_obstacle.z_max_m"),
/// a scan's points that are not whole 12-byte points or hold a NaN or infinite coordinate
/// (refused, with its index: "edits[1].scan.points"); kResourceExhausted for a scan of more
/// than kMaxEditPoints points. A scan's region is checked against the map's grid later, by
/// ApplyEdits.
Result<ParsedMapEdits> MapEditsFromProto(const v1::UpdateMapRequest& request);
/// Most edits in one UpdateMapRequest.
inline constexpr int kMaxMapEdits = 64;

/// What a map store keeps beside an ACTIVE version (RegistryOptions::encode_metadata): its Map
/// as JSON, readable by operators, without memory_bytes (the holder's).
std::string EncodeMapMetadata(const MapSnapshot& snapshot);
/// The snapshot EncodeMapMetadata wrote (file sources lose their resolved path, which only
/// the creating server knew); kMapLoadFailed for text that is not a Map.
Result<MapSnapshot> DecodeMapMetadata(const std::string& json);

/// The profile of a request: a built-in by name, or inline over the defaults and validated by
/// RobotProfile::Validate. kInvalidInput (unset, unknown name: "profile_name"),
/// kInvalidConfig ("profile.<field>", the same path in the planner and in PlanRequest).
Result<RobotProfile> ProfileFromRequest(const v1::PlanRequest& request);
/// The same for EstimateCosts, whose robot is the same oneof.
Result<RobotProfile> ProfileFromRequest(const v1::EstimateCostsRequest& request);
/// The robot of a GetMapGeometryRequest, as ProfileFromRequest; nullopt when none is set.
Result<std::optional<RobotProfile>> ProfileFromRequest(const v1::GetMapGeometryRequest& request);
/// Every field set.
void ToProto(const RobotProfile& profile, v1::RobotProfile* message);
/// An inline profile over the defaults (its unset fields), validated: kInvalidConfig blaming
/// "profile.<field>".
Result<RobotProfile> ProfileFromProto(const v1::RobotProfile& message);

/// A start or goal, copied; kInvalidInput for a missing position (blaming
/// "<field>.position_m"). PlanRequest::Validate checks the values.
Result<RobotState> FromProto(const v1::RobotState& state, const std::string& field);

/// A prism, copied; kInvalidInput blaming "<field>.z_min_m" or "<field>.z_max_m" when one is
/// unset (a prism has no default height). Prism::Validate(field) checks the values and blames
/// the same paths, e.g. "keep_out[1].polygon_m[2].x".
Result<Prism> FromProto(const v1::Prism& message, const std::string& field);
void ToProto(const Prism& prism, v1::Prism* message);
/// The request's keep-out zones, copied (FromProto above); kInvalidInput blaming "keep_out"
/// for more than kMaxRequestKeepOutZones. PlanRequest::Validate checks the zones.
Result<std::vector<Prism>> KeepOutFromRequest(const v1::PlanRequest& request);
/// The same for EstimateCosts.
Result<std::vector<Prism>> KeepOutFromRequest(const v1::EstimateCostsRequest& request);

/// The request's vias, copied; kInvalidInput blaming "via" for more than kMaxVias (checked
/// first, so a huge list costs nothing to refuse) and "via[i].position_m" for a missing
/// position. PlanRequest::Validate checks the values (e.g. "via[0].position_m.x").
Result<std::vector<Via>> ViasFromRequest(const v1::PlanRequest& request);

void ToProto(const Eigen::Vector3d& v, v1::Vector3* message);
/// Positions, copied (TravelCostQuery::Prepare checks them, blaming e.g. "starts_m[2].x").
std::vector<Eigen::Vector3d> PositionsFromProto(
    const google::protobuf::RepeatedPtrField<v1::Vector3>& positions);
/// The ends and cells of an estimate (everything of the response but profile, map_version and
/// stats): a failed end or cell carries its reason from the error table (error_mapping.hpp).
void ToProto(const TravelCostQuery& query, const TravelCostMatrix& matrix,
             double reference_height_m, v1::EstimateCostsResponse* response);

/// Options over the planner's defaults, copied (time_budget_s as given: the caller caps it,
/// see PlannerService); PlanOptions::Validate checks them.
PlanOptions FromProto(const v1::PlanOptions& options);
/// Sets every field of the message but sample_dt_s (a server option, not the planner's).
void ToProto(const PlanOptions& options, v1::PlanOptions* message);

/// The PlanRequest field of a planner field path (Error::field of PlanRequest::Validate or
/// Plan), or "" when the request has no such field (a setting it cannot override). The paths
/// are the same by design ("start.position_m.x", "profile.max_tilt_rad",
/// "options.max_attempts", "keep_out[1].polygon_m[2].x"), with two exceptions: the weights
/// ("options.optimizer.weights.X" is the request's "options.weights.X", one table in
/// proto_convert.cpp), and a profile field of a built-in profile, which the request chose by
/// "profile_name"
/// (`inline_profile` false).
std::string PlanRequestField(const std::string& planner_field, bool inline_profile);

void ToProto(const Trajectory& trajectory, v1::Trajectory* message);
/// The inverse of ToProto (clients and tests); kInvalidInput naming the field for a piece
/// with a non-positive duration or the wrong number of axes or coefficients.
Result<Trajectory> FromProto(const v1::Trajectory& message);

/// A warm start: its trajectory as FromProto reads it (fields blamed under
/// "warm_start.trajectory."), at most kMaxWarmStartPieces pieces, elapsed_s >= 0 and finite when
/// set (-1 when not). PlanRequest::Validate checks the trajectory against the profile.
Result<WarmStart> WarmStartFromRequest(const v1::WarmStart& message);

/// `snap` for a robot whose reference point is `reference_height_m` above the ground.
void ToProto(const SnapResult& snap, double reference_height_m, v1::SnappedState* message);
/// The search's path into PlanResponse.search_path_m.
void AppendSearchPath(const PathResult& path, v1::PlanResponse* response);
/// Every field but map_id, map_version and safety_height_m, which are the caller's.
void ToProto(const MapGeometryData& geometry, v1::MapGeometry* message);
void ToProto(const PlanStats& stats, v1::PlanStats* message);

/// Samples every `dt_s` from 0 to the end (which is always included); kInvalidInput
/// blaming "options.sample_dt_s" when that makes more than `max_samples`.
ServiceStatus AppendSamples(const Trajectory& trajectory, double dt_s, int max_samples,
                            v1::PlanResponse* response);

}  // namespace strata::server
