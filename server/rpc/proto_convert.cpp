#include "rpc/proto_convert.hpp"

#include "common/map_id.hpp"

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include "common/packed_points.hpp"
#include "rpc/error_mapping.hpp"

namespace strata::server {

void ToProto(const Eigen::Vector3d& v, v1::Vector3* message) {
  message->set_x(v.x());
  message->set_y(v.y());
  message->set_z(v.z());
}

namespace {

using google::protobuf::Timestamp;

void ToProto(std::chrono::system_clock::time_point time, Timestamp* message) {
  const auto since_epoch = time.time_since_epoch();
  const auto seconds = std::chrono::floor<std::chrono::seconds>(since_epoch);
  message->set_seconds(seconds.count());
  message->set_nanos(static_cast<int>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(since_epoch - seconds).count()));
}

Eigen::Vector3d FromProto(const v1::Vector3& v) { return {v.x(), v.y(), v.z()}; }

// One optional terrain field: its name in TerrainParameters, its path in AssessmentConfig
// (Error::field) and where it lands there. The one table of terrain names: the proto
// flattens the planner's per-stage structs.
struct TerrainField {
  const char* name;
  const char* planner_field;
  std::function<bool(const v1::TerrainParameters&)> has;
  std::function<double(const v1::TerrainParameters&)> get;
  std::function<double&(AssessmentConfig&)> slot;
};

const std::vector<TerrainField>& TerrainFields() {
  using T = v1::TerrainParameters;
  static const std::vector<TerrainField> fields = {
      {"resolution_m", "grid.resolution_m", &T::has_resolution_m, &T::resolution_m,
       [](AssessmentConfig& c) -> double& { return c.grid.resolution_m; }},
      {"ground_radius_m", "ground.radius_m", &T::has_ground_radius_m, &T::ground_radius_m,
       [](AssessmentConfig& c) -> double& { return c.ground.radius_m; }},
      {"max_tilt_rad", "ground.max_tilt_rad", &T::has_max_tilt_rad, &T::max_tilt_rad,
       [](AssessmentConfig& c) -> double& { return c.ground.max_tilt_rad; }},
      {"height_tolerance_m", "ground.height_tolerance_m", &T::has_height_tolerance_m,
       &T::height_tolerance_m,
       [](AssessmentConfig& c) -> double& { return c.ground.height_tolerance_m; }},
      {"padding_m", "grid.padding_m", &T::has_padding_m, &T::padding_m,
       [](AssessmentConfig& c) -> double& { return c.grid.padding_m; }},
  };
  return fields;
}

// Planner field paths (PlanRequest) whose request path differs: PlanOptions keeps the
// weights, the safety threshold and the rim weight inside its optimiser and search settings,
// the proto beside the other options. Every other path is the same in both by design
// (RobotState, RobotProfile, PlanOptions' own fields).
constexpr std::pair<std::string_view, std::string_view> kPlanRequestRenames[] = {
    {"options.optimizer.weights.", "options.weights."},
    {"options.optimizer.cost.safety_threshold", "options.safety_threshold"},
    {"options.search.rim_weight", "options.rim_weight"},
};

// Whether `path` ("options.weights.safety", "keep_out[1].polygon_m[2].x": field names joined
// by dots, a repeated field's with an index) names a field of `message`.
bool HasFieldPath(const google::protobuf::Descriptor* message, std::string_view path) {
  while (message != nullptr) {
    const std::size_t dot = path.find('.');
    std::string_view name = path.substr(0, dot);
    const std::size_t bracket = name.find('[');
    const bool indexed = bracket != std::string_view::npos;
    if (indexed) name = name.substr(0, bracket);
    const google::protobuf::FieldDescriptor* field = message->FindFieldByName(std::string(name));
    if (field == nullptr || (indexed && !field->is_repeated())) return false;
    if (dot == std::string_view::npos) return true;
    message = field->message_type();
    path.remove_prefix(dot + 1);
  }
  return false;
}

}  // namespace

std::string PlanRequestField(const std::string& planner_field, bool inline_profile) {
  if (planner_field.rfind("profile.", 0) == 0 && !inline_profile) return "profile_name";
  std::string field = planner_field;
  for (const auto& [planner_prefix, request_prefix] : kPlanRequestRenames) {
    if (field.rfind(planner_prefix, 0) == 0) {
      field.replace(0, planner_prefix.size(), request_prefix);
      break;
    }
  }
  return HasFieldPath(v1::PlanRequest::descriptor(), field) ? field : std::string();
}

std::string TerrainRequestField(const std::string& planner_field, const std::string& field) {
  for (const TerrainField& f : TerrainFields()) {
    if (planner_field == f.planner_field) return field + "." + f.name;
  }
  return field;
}

Result<AssessmentConfig> FromProto(const v1::TerrainParameters& terrain, const std::string& field) {
  AssessmentConfig config;
  for (const TerrainField& f : TerrainFields()) {
    if (f.has(terrain)) f.slot(config) = f.get(terrain);
  }
  if (Status valid = config.Validate(); !valid) {
    return ServiceError::FromPlanner(valid.error(),
                                     TerrainRequestField(valid.error().field, field));
  }
  return config;
}

void ToProto(const AssessmentConfig& config, v1::TerrainParameters* terrain) {
  terrain->set_resolution_m(config.grid.resolution_m);
  terrain->set_ground_radius_m(config.ground.radius_m);
  terrain->set_max_tilt_rad(config.ground.max_tilt_rad);
  terrain->set_height_tolerance_m(config.ground.height_tolerance_m);
  terrain->set_padding_m(config.grid.padding_m);
}

void ToProto(const MapSnapshot& s, v1::Map* map) {
  map->set_id(s.id);
  switch (s.state) {
    case MapState::kCreating: map->set_state(v1::MAP_STATE_CREATING); break;
    case MapState::kActive: map->set_state(v1::MAP_STATE_ACTIVE); break;
    case MapState::kFailed: map->set_state(v1::MAP_STATE_FAILED); break;
  }
  switch (s.stage) {
    case CreationStage::kQueued: map->set_stage(v1::MAP_CREATION_STAGE_QUEUED); break;
    case CreationStage::kLoading: map->set_stage(v1::MAP_CREATION_STAGE_LOADING); break;
    case CreationStage::kAssessing: map->set_stage(v1::MAP_CREATION_STAGE_ASSESSING); break;
    case CreationStage::kDone: map->set_stage(v1::MAP_CREATION_STAGE_DONE); break;
  }
  map->set_progress(s.progress());
  if (s.state == MapState::kCreating && s.stage == CreationStage::kAssessing) {
    map->set_assessment_step(AssessmentStageName(s.assessment_step));
  }
  map->set_from_saved_model(s.from_saved_model);
  if (s.failure.has_value()) {
    map->mutable_failure()->set_reason(std::string(MapError(s.failure->code).reason));
    map->mutable_failure()->set_message(s.failure->message);
  }
  if (const auto* file = std::get_if<FileSourceInfo>(&s.source)) {
    map->mutable_source()->mutable_file()->set_path(file->requested_path);
  } else if (const auto* scene = std::get_if<SceneMapSource>(&s.source)) {
    v1::SceneSource* out = map->mutable_source()->mutable_scene();
    out->set_name(scene->name);
    out->set_seed(scene->seed);
    if (scene->options.size_m) out->set_size_m(*scene->options.size_m);
    if (scene->options.spacing_m) out->set_spacing_m(*scene->options.spacing_m);
  } else {
    map->mutable_source()->mutable_upload()->set_received_bytes(
        std::get<UploadSummary>(s.source).received_bytes);
  }
  ToProto(s.config, map->mutable_terrain());
  map->set_raw_point_count(s.raw_point_count);
  map->set_dropped_nonfinite_point_count(s.dropped_nonfinite_point_count);
  map->mutable_assessment_seconds()->set_load_s(s.load_s);
  if (s.state == MapState::kActive) {
    const AssessmentSummary& summary = s.summary;
    ToProto(summary.cloud_bounds_m.min(), map->mutable_bounds_m()->mutable_min_m());
    ToProto(summary.cloud_bounds_m.max(), map->mutable_bounds_m()->mutable_max_m());
    map->set_input_point_count(summary.input_points);
    map->set_valid_ground_point_count(summary.valid_ground_points);
    map->mutable_grid_size()->set_nx(s.grid.size.x());
    map->mutable_grid_size()->set_ny(s.grid.size.y());
    map->mutable_grid_size()->set_nz(s.grid.size.z());
    ToProto(s.grid.origin_m, map->mutable_grid_origin_m());
    map->set_memory_bytes(s.memory_bytes);
    v1::AssessmentSeconds* seconds = map->mutable_assessment_seconds();
    seconds->set_ground_filter_s(summary.timings.ground_filter_s);
    seconds->set_surfaces_s(summary.timings.surfaces_s);
    seconds->set_fields_s(summary.timings.fields_s);
    seconds->set_total_s(summary.timings.total_s);
    map->set_surface_count(summary.surface_count);
    map->set_valid_surface_count(summary.valid_surface_count);
    map->set_max_levels(static_cast<std::uint32_t>(s.max_levels));
  }
  ToProto(s.create_time, map->mutable_create_time());
  if (s.done_time.has_value()) ToProto(*s.done_time, map->mutable_done_time());
  map->set_version(s.version);
  for (const std::string& version : s.versions) map->add_versions(version);
  for (const Prism& zone : s.keep_out) ToProto(zone, map->add_keep_out());
}

namespace {

std::chrono::system_clock::time_point FromProto(const Timestamp& time) {
  return std::chrono::system_clock::time_point(
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::seconds(time.seconds()) + std::chrono::nanoseconds(time.nanos())));
}

// The snapshot of an ACTIVE map a Map describes (the inverse of ToProto for what a stored
// version keeps; memory_bytes is the holder's to fill).
Result<MapSnapshot> SnapshotFromProto(const v1::Map& map) {
  MapSnapshot s;
  s.id = map.id();
  s.state = MapState::kActive;
  s.stage = CreationStage::kDone;
  switch (map.source().kind_case()) {
    case v1::MapSource::kFile: s.source = FileSourceInfo{map.source().file().path()}; break;
    case v1::MapSource::kScene: {
      SceneMapSource scene;
      scene.name = map.source().scene().name();
      scene.seed = map.source().scene().seed();
      if (map.source().scene().has_size_m()) scene.options.size_m = map.source().scene().size_m();
      if (map.source().scene().has_spacing_m()) {
        scene.options.spacing_m = map.source().scene().spacing_m();
      }
      s.source = scene;
      break;
    }
    default: s.source = UploadSummary{map.source().upload().received_bytes()}; break;
  }
  Result<AssessmentConfig> config = server::FromProto(map.terrain(), "terrain");
  if (!config.ok()) return std::move(config).error();
  s.config = config.value();
  s.raw_point_count = map.raw_point_count();
  s.dropped_nonfinite_point_count = map.dropped_nonfinite_point_count();
  s.load_s = map.assessment_seconds().load_s();
  s.from_saved_model = map.from_saved_model();
  AssessmentSummary& summary = s.summary;
  summary.cloud_bounds_m =
      Eigen::AlignedBox3d(FromProto(map.bounds_m().min_m()), FromProto(map.bounds_m().max_m()));
  summary.input_points = map.input_point_count();
  summary.valid_ground_points = map.valid_ground_point_count();
  summary.surface_count = map.surface_count();
  summary.valid_surface_count = map.valid_surface_count();
  summary.timings.ground_filter_s = map.assessment_seconds().ground_filter_s();
  summary.timings.surfaces_s = map.assessment_seconds().surfaces_s();
  summary.timings.fields_s = map.assessment_seconds().fields_s();
  summary.timings.total_s = map.assessment_seconds().total_s();
  s.grid.size = {map.grid_size().nx(), map.grid_size().ny(), map.grid_size().nz()};
  s.grid.origin_m = FromProto(map.grid_origin_m());
  s.grid.resolution_m = s.config.grid.resolution_m;
  s.max_levels = static_cast<int>(map.max_levels());
  s.create_time = FromProto(map.create_time());
  if (map.has_done_time()) s.done_time = FromProto(map.done_time());
  s.version = map.version();
  s.versions.assign(map.versions().begin(), map.versions().end());
  for (int i = 0; i < map.keep_out_size(); ++i) {
    Result<Prism> zone = server::FromProto(map.keep_out(i), "keep_out[" + std::to_string(i) + "]");
    if (!zone.ok()) return std::move(zone).error();
    s.keep_out.push_back(std::move(zone).value());
  }
  return s;
}

}  // namespace

namespace {

// FromProto, then Prism::Validate blaming the same request path.
Result<Prism> ValidPrism(const v1::Prism& message, const std::string& field) {
  Result<Prism> prism = server::FromProto(message, field);
  if (!prism.ok()) return prism;
  if (Status valid = prism.value().Validate(field); !valid) {
    const std::string blamed = valid.error().field.empty() ? field : valid.error().field;
    return ServiceError::FromPlanner(valid.error(), blamed);
  }
  return prism;
}

// A scan's points (XYZ_F32_LE, common/packed_points.hpp), all finite; the errors blame
// `field` (edits[i].scan.points).
Result<std::shared_ptr<const PointCloud>> ScanPointsFromProto(const std::string& bytes,
                                                              const std::string& field) {
  if (bytes.size() % kPackedPointBytes != 0) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("{} holds {} bytes, not a whole number of 12-byte points "
                                 "(little-endian float32 x, y, z)",
                                 field, bytes.size()))
        .Blame(field);
  }
  const std::size_t count = bytes.size() / kPackedPointBytes;
  if (count > kMaxEditPoints) {
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("{} holds {} points, more than the {} an update may add: split "
                                 "the scan into smaller regions over several updates",
                                 field, count, kMaxEditPoints))
        .Blame(field);
  }
  auto points = std::make_shared<PointCloud>();
  points->reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3f p = ReadPackedPoint(bytes.data() + i * kPackedPointBytes);
    if (!p.allFinite()) {
      // Refused, not dropped: a scan replaces the map in its region, and a sensor that returns
      // NaN for what it did not see must not have its other points taken for the whole view.
      return MakeError(ErrorCode::kInvalidInput,
                       fmt::format("{} holds a point that is not finite at index {}: ({}, {}, {}) "
                                   "m; drop it before sending",
                                   field, i, p.x(), p.y(), p.z()))
          .Blame(field);
    }
    points->push_back(p);
  }
  return std::shared_ptr<const PointCloud>(std::move(points));
}

}  // namespace

Result<ParsedMapEdits> MapEditsFromProto(const v1::UpdateMapRequest& request) {
  if (ServiceStatus given = RequireMapId(request.map_id()); !given.ok()) {
    return std::move(given).error();
  }
  const int count = request.edits_size();
  if ((count == 0 && !request.clear_keep_out()) || count > kMaxMapEdits) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("edits has {} edits: give 1 to {} (or none with clear_keep_out)",
                                 count, kMaxMapEdits))
        .Blame("edits");
  }
  ParsedMapEdits parsed;
  for (int i = 0; i < count; ++i) {
    const v1::MapEdit& edit = request.edits(i);
    const std::string path = "edits[" + std::to_string(i) + "]";
    switch (edit.kind_case()) {
      case v1::MapEdit::kAddObstacle:
      case v1::MapEdit::kRemovePoints: {
        const bool obstacle = edit.kind_case() == v1::MapEdit::kAddObstacle;
        Result<Prism> region = ValidPrism(obstacle ? edit.add_obstacle() : edit.remove_points(),
                                          path + (obstacle ? ".add_obstacle" : ".remove_points"));
        if (!region.ok()) return std::move(region).error();
        parsed.edits.push_back(
            MapEdit{obstacle ? MapEdit::Kind::kAddObstacle : MapEdit::Kind::kRemovePoints,
                    std::move(region).value(), nullptr});
        break;
      }
      case v1::MapEdit::kScan: {
        Result<Prism> region = ValidPrism(edit.scan().region(), path + ".scan.region");
        if (!region.ok()) return std::move(region).error();
        Result<std::shared_ptr<const PointCloud>> points =
            ScanPointsFromProto(edit.scan().points(), path + ".scan.points");
        if (!points.ok()) return std::move(points).error();
        parsed.edits.push_back(
            MapEdit{MapEdit::Kind::kScan, std::move(region).value(), std::move(points).value()});
        break;
      }
      case v1::MapEdit::kAddKeepOut: {
        // Kept in the map and read by every plan on it: checked here, where the client hears
        // which field to fix (a zone a plan request carries is checked by the planner).
        Result<Prism> zone = ValidPrism(edit.add_keep_out(), path + ".add_keep_out");
        if (!zone.ok()) return std::move(zone).error();
        parsed.add_keep_out.push_back(std::move(zone).value());
        break;
      }
      case v1::MapEdit::KIND_NOT_SET:
        return MakeError(
                   ErrorCode::kInvalidInput,
                   path + " sets no edit: set add_obstacle, remove_points, add_keep_out or scan")
            .Blame(path);
    }
  }
  return parsed;
}

std::string EncodeMapMetadata(const MapSnapshot& snapshot) {
  v1::Map map;
  ToProto(snapshot, &map);
  map.clear_memory_bytes();  // The holder's, not the version's.
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;  // For operators who look into the store.
  (void)google::protobuf::util::MessageToJsonString(map, &json, options);
  return json;
}

Result<MapSnapshot> DecodeMapMetadata(const std::string& json) {
  v1::Map map;
  if (const auto parsed = google::protobuf::util::JsonStringToMessage(json, &map); !parsed.ok()) {
    return MakeError(ErrorCode::kMapLoadFailed,
                     "the map store holds a version description that is not a Map (" +
                         std::string(parsed.message()) + "): delete the map and create it again");
  }
  return SnapshotFromProto(map);
}

Result<RobotProfile> ProfileFromProto(const v1::RobotProfile& m) {
  RobotProfile p;
  p.name = m.has_name() ? m.name() : "custom";
  if (m.has_footprint_radius_m()) p.footprint_radius_m = m.footprint_radius_m();
  if (m.has_max_tilt_rad()) p.max_tilt_rad = m.max_tilt_rad();
  if (m.has_max_step_m()) p.max_step_m = m.max_step_m();
  if (m.has_reference_height_m()) p.reference_height_m = m.reference_height_m();
  if (m.has_max_speed_horizontal_mps()) p.max_speed_horizontal_mps = m.max_speed_horizontal_mps();
  if (m.has_max_speed_vertical_mps()) p.max_speed_vertical_mps = m.max_speed_vertical_mps();
  if (m.has_max_accel_horizontal_mps2()) {
    p.max_accel_horizontal_mps2 = m.max_accel_horizontal_mps2();
  }
  if (m.has_max_accel_vertical_mps2()) p.max_accel_vertical_mps2 = m.max_accel_vertical_mps2();
  if (m.has_active_height()) p.active_height = m.active_height();
  if (m.has_body_height_m()) p.body_height_m = m.body_height_m();
  if (m.has_body_height_min_m()) p.body_height_min_m = m.body_height_min_m();
  if (m.has_body_height_max_m()) p.body_height_max_m = m.body_height_max_m();
  if (m.has_headroom_m()) p.headroom_m = m.headroom_m();
  // RobotProfile::Validate blames "profile.<field>", the field's path in the request too.
  if (Status valid = p.Validate("profile"); !valid) {
    return ServiceError::FromPlanner(valid.error(), valid.error().field);
  }
  return p;
}

namespace {

// A built-in profile by name.
Result<RobotProfile> NamedProfile(const std::string& name) {
  Expected<RobotProfile> builtin = BuiltinProfile(name);
  if (!builtin) return ServiceError::FromPlanner(builtin.error(), "profile_name");
  return std::move(builtin).value();
}

// The robot of a request whose oneof `robot` must be set (PlanRequest, EstimateCostsRequest).
template <typename Request>
Result<RobotProfile> RequiredProfile(const Request& request) {
  switch (request.robot_case()) {
    case Request::kProfileName: return NamedProfile(request.profile_name());
    case Request::kProfile: return ProfileFromProto(request.profile());
    case Request::ROBOT_NOT_SET: break;
  }
  return MakeError(ErrorCode::kInvalidInput,
                   "no robot given: set profile_name (\"differential\" or \"biped\") or an "
                   "inline profile")
      .Blame("profile_name");
}

}  // namespace

Result<RobotProfile> ProfileFromRequest(const v1::PlanRequest& request) {
  return RequiredProfile(request);
}

Result<RobotProfile> ProfileFromRequest(const v1::EstimateCostsRequest& request) {
  return RequiredProfile(request);
}

Result<std::optional<RobotProfile>> ProfileFromRequest(const v1::GetMapGeometryRequest& request) {
  Result<RobotProfile> profile = MakeError(ErrorCode::kInvalidInput, "");
  switch (request.robot_case()) {
    case v1::GetMapGeometryRequest::kProfileName:
      profile = NamedProfile(request.profile_name());
      break;
    case v1::GetMapGeometryRequest::kProfile: profile = ProfileFromProto(request.profile()); break;
    case v1::GetMapGeometryRequest::ROBOT_NOT_SET: return std::optional<RobotProfile>();
  }
  if (!profile.ok()) return std::move(profile).error();
  return std::optional<RobotProfile>(std::move(profile).value());
}

void ToProto(const RobotProfile& p, v1::RobotProfile* m) {
  m->set_name(p.name);
  m->set_footprint_radius_m(p.footprint_radius_m);
  m->set_max_tilt_rad(p.max_tilt_rad);
  m->set_max_step_m(p.max_step_m);
  m->set_reference_height_m(p.reference_height_m);
  m->set_max_speed_horizontal_mps(p.max_speed_horizontal_mps);
  m->set_max_speed_vertical_mps(p.max_speed_vertical_mps);
  m->set_max_accel_horizontal_mps2(p.max_accel_horizontal_mps2);
  m->set_max_accel_vertical_mps2(p.max_accel_vertical_mps2);
  m->set_active_height(p.active_height);
  m->set_body_height_m(p.body_height_m);
  m->set_body_height_min_m(p.body_height_min_m);
  m->set_body_height_max_m(p.body_height_max_m);
  m->set_headroom_m(p.headroom_m);
}

Result<RobotState> FromProto(const v1::RobotState& state, const std::string& field) {
  if (!state.has_position_m()) {
    return MakeError(ErrorCode::kInvalidInput, field + ".position_m is required")
        .Blame(field + ".position_m");
  }
  RobotState result;
  result.position_m = FromProto(state.position_m());
  if (state.has_velocity_mps()) result.velocity_mps = FromProto(state.velocity_mps());
  if (state.has_acceleration_mps2()) {
    result.acceleration_mps2 = FromProto(state.acceleration_mps2());
  }
  return result;
}

Result<Prism> FromProto(const v1::Prism& message, const std::string& field) {
  // Unset heights would silently make a zone of zero height at z = 0.
  for (const auto& [name, present] :
       {std::pair{"z_min_m", message.has_z_min_m()}, std::pair{"z_max_m", message.has_z_max_m()}}) {
    if (!present) {
      const std::string path = field + "." + name;
      return MakeError(ErrorCode::kInvalidInput,
                       path + " is required: give the prism's height range in the map's frame")
          .Blame(path);
    }
  }
  Prism prism;
  prism.polygon_m.reserve(static_cast<std::size_t>(message.polygon_m_size()));
  for (const v1::Vector2& corner : message.polygon_m()) {
    prism.polygon_m.emplace_back(corner.x(), corner.y());
  }
  prism.z_min_m = message.z_min_m();
  prism.z_max_m = message.z_max_m();
  return prism;
}

void ToProto(const Prism& prism, v1::Prism* message) {
  message->clear_polygon_m();
  for (const Eigen::Vector2d& corner : prism.polygon_m) {
    v1::Vector2* c = message->add_polygon_m();
    c->set_x(corner.x());
    c->set_y(corner.y());
  }
  message->set_z_min_m(prism.z_min_m);
  message->set_z_max_m(prism.z_max_m);
}

namespace {

// The keep-out zones of a request with PlanRequest's `keep_out` (PlanRequest,
// EstimateCostsRequest).
template <typename Request>
Result<std::vector<Prism>> KeepOutOf(const Request& request) {
  std::vector<Prism> zones;
  // Only the count is checked first, so that a huge list costs nothing to refuse; the rest is
  // Prism::Validate's (PlanRequest::Validate's, the same paths).
  if (request.keep_out_size() > kMaxRequestKeepOutZones) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("keep_out has {} zones, more than the {} one request may carry: "
                                 "merge neighbouring zones",
                                 request.keep_out_size(), kMaxRequestKeepOutZones))
        .Blame("keep_out");
  }
  for (int i = 0; i < request.keep_out_size(); ++i) {
    Result<Prism> zone =
        server::FromProto(request.keep_out(i), "keep_out[" + std::to_string(i) + "]");
    if (!zone.ok()) return std::move(zone).error();
    zones.push_back(std::move(zone).value());
  }
  return zones;
}

}  // namespace

Result<std::vector<Prism>> KeepOutFromRequest(const v1::PlanRequest& request) {
  return KeepOutOf(request);
}
Result<std::vector<Prism>> KeepOutFromRequest(const v1::EstimateCostsRequest& request) {
  return KeepOutOf(request);
}

Result<std::vector<Via>> ViasFromRequest(const v1::PlanRequest& request) {
  if (request.via_size() > kMaxVias) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("via has {} points, more than the {} one request may carry: "
                                 "split the route into several plans",
                                 request.via_size(), kMaxVias))
        .Blame("via");
  }
  std::vector<Via> vias;
  vias.reserve(static_cast<std::size_t>(request.via_size()));
  for (int i = 0; i < request.via_size(); ++i) {
    const v1::Via& via = request.via(i);
    if (!via.has_position_m()) {
      const std::string field = "via[" + std::to_string(i) + "].position_m";
      return MakeError(ErrorCode::kInvalidInput, field + " is required").Blame(field);
    }
    vias.push_back(Via{FromProto(via.position_m()), via.stop()});
  }
  return vias;
}

std::vector<Eigen::Vector3d> PositionsFromProto(
    const google::protobuf::RepeatedPtrField<v1::Vector3>& positions) {
  std::vector<Eigen::Vector3d> result;
  result.reserve(static_cast<std::size_t>(positions.size()));
  for (const v1::Vector3& p : positions) result.push_back(FromProto(p));
  return result;
}

void ToProto(const TravelCostQuery& query, const TravelCostMatrix& matrix,
             double reference_height_m, v1::EstimateCostsResponse* response) {
  const auto ends = [reference_height_m](const std::vector<Expected<SnapResult>>& from,
                                         google::protobuf::RepeatedPtrField<v1::CostEndpoint>* to) {
    to->Reserve(static_cast<int>(from.size()));
    for (const Expected<SnapResult>& end : from) {
      v1::CostEndpoint* out = to->Add();
      if (end) {
        ToProto(*end, reference_height_m, out->mutable_snapped());
      } else {
        out->set_reason(std::string(MapError(end.error().code).reason));
        out->set_message(BoundedText(end.error().message, kMaxErrorMessageBytes));
      }
    }
  };
  ends(query.starts(), response->mutable_starts());
  ends(query.goals(), response->mutable_goals());
  response->mutable_cells()->Reserve(static_cast<int>(matrix.cells.size()));
  for (const TravelCost& cell : matrix.cells) {
    v1::CostCell* out = response->add_cells();
    out->set_reachable(cell.reachable());
    if (cell.reachable()) {
      out->set_time_s(cell.time_s);
      out->set_length_m(cell.length_m);
    } else {
      out->set_reason(std::string(MapError(*cell.failure).reason));
    }
  }
}

PlanOptions FromProto(const v1::PlanOptions& m) {
  PlanOptions options;
  if (m.has_time_budget_s()) options.time_budget_s = m.time_budget_s();
  if (m.has_snap_tolerance_m()) options.snap_tolerance_m = m.snap_tolerance_m();
  if (m.has_max_attempts()) options.max_attempts = m.max_attempts();
  if (m.has_safety_threshold()) options.optimizer.cost.safety_threshold = m.safety_threshold();
  if (m.has_rim_weight()) options.search.rim_weight = m.rim_weight();
  const v1::CostWeights& w = m.weights();
  CostWeights& weights = options.optimizer.weights;
  if (w.has_smoothness()) weights.smoothness = w.smoothness();
  if (w.has_time()) weights.time = w.time();
  if (w.has_safety()) weights.safety = w.safety();
  if (w.has_ground()) weights.ground = w.ground();
  if (w.has_feasibility()) weights.feasibility = w.feasibility();
  if (w.has_height()) weights.height = w.height();
  if (w.has_turning()) weights.turning = w.turning();
  return options;
}

void ToProto(const PlanOptions& options, v1::PlanOptions* m) {
  m->set_time_budget_s(options.time_budget_s);
  m->set_snap_tolerance_m(options.snap_tolerance_m);
  m->set_max_attempts(options.max_attempts);
  m->set_safety_threshold(options.optimizer.cost.safety_threshold);
  m->set_rim_weight(options.search.rim_weight);
  const CostWeights& weights = options.optimizer.weights;
  v1::CostWeights* w = m->mutable_weights();
  w->set_smoothness(weights.smoothness);
  w->set_time(weights.time);
  w->set_safety(weights.safety);
  w->set_ground(weights.ground);
  w->set_feasibility(weights.feasibility);
  w->set_height(weights.height);
  w->set_turning(weights.turning);
}

void ToProto(const Trajectory& trajectory, v1::Trajectory* message) {
  message->set_frame("map");
  message->set_dimension(trajectory.dimension);
  for (const TrajectoryPiece& piece : trajectory.pieces) {
    v1::TrajectoryPiece* p = message->add_pieces();
    p->set_duration_s(piece.duration_s);
    for (int axis = 0; axis < trajectory.dimension; ++axis) {
      v1::Polynomial* polynomial = p->add_axes();
      for (int k = 0; k < piece.coefficients.rows(); ++k) {
        polynomial->add_coefficients(piece.coefficients(k, axis));
      }
    }
  }
  message->set_duration_s(trajectory.TotalDuration());
}

Result<Trajectory> FromProto(const v1::Trajectory& message) {
  if (message.dimension() != 3 && message.dimension() != 4) {
    return MakeError(
               ErrorCode::kInvalidInput,
               fmt::format("trajectory dimension must be 3 or 4, got {}", message.dimension()))
        .Blame("dimension");
  }
  Trajectory trajectory;
  trajectory.dimension = message.dimension();
  for (int i = 0; i < message.pieces_size(); ++i) {
    const v1::TrajectoryPiece& p = message.pieces(i);
    const std::string field = "pieces[" + std::to_string(i) + "]";
    if (!(std::isfinite(p.duration_s()) && p.duration_s() > 0)) {
      return MakeError(ErrorCode::kInvalidInput, field + ".duration_s must be > 0 and finite")
          .Blame(field + ".duration_s");
    }
    if (p.axes_size() != message.dimension()) {
      return MakeError(ErrorCode::kInvalidInput, field + " must have one polynomial per axis")
          .Blame(field + ".axes");
    }
    TrajectoryPiece piece;
    piece.duration_s = p.duration_s();
    piece.coefficients.resize(6, message.dimension());
    for (int axis = 0; axis < message.dimension(); ++axis) {
      if (p.axes(axis).coefficients_size() != 6) {
        return MakeError(ErrorCode::kInvalidInput, field + " must have 6 coefficients per axis")
            .Blame(field + ".axes[" + std::to_string(axis) + "].coefficients");
      }
      for (int k = 0; k < 6; ++k) piece.coefficients(k, axis) = p.axes(axis).coefficients(k);
    }
    trajectory.pieces.push_back(std::move(piece));
  }
  return trajectory;
}

Result<WarmStart> WarmStartFromRequest(const v1::WarmStart& message) {
  constexpr const char* kPrefix = "warm_start.trajectory";
  if (message.trajectory().pieces_size() < 1 ||
      static_cast<std::size_t>(message.trajectory().pieces_size()) > kMaxWarmStartPieces) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("{}.pieces has {} pieces; give 1 to {}", kPrefix,
                                 message.trajectory().pieces_size(), kMaxWarmStartPieces))
        .Blame(std::string(kPrefix) + ".pieces");
  }
  Result<Trajectory> trajectory = FromProto(message.trajectory());
  if (!trajectory.ok()) {
    ServiceError error = std::move(trajectory).error();
    for (FieldViolation& violation : error.field_violations) {
      violation.field = std::string(kPrefix) + "." + violation.field;
    }
    // The messages start with the field they blame ("pieces[3].duration_s must be > 0"),
    // or speak of "trajectory dimension".
    error.message = std::string(kPrefix) +
                    (error.message.rfind("trajectory ", 0) == 0 ? ": " : ".") + error.message;
    return error;
  }
  WarmStart warm;
  warm.trajectory = std::move(trajectory).value();
  if (message.has_elapsed_s()) {
    const double elapsed = message.elapsed_s();
    if (!(std::isfinite(elapsed) && elapsed >= 0)) {
      return MakeError(ErrorCode::kInvalidInput,
                       fmt::format("warm_start.elapsed_s = {:f} must be >= 0 and finite (or unset)",
                                   elapsed))
          .Blame("warm_start.elapsed_s");
    }
    warm.elapsed_s = elapsed;
  }
  return warm;
}

void ToProto(const SnapResult& snap, double reference_height_m, v1::SnappedState* message) {
  ToProto(snap.position_m, message->mutable_position_m());
  message->set_ground_height_m(snap.position_m.z() - reference_height_m);
  message->set_level(static_cast<std::uint32_t>(std::max(0, snap.level)));
  message->set_distance_m(snap.distance_m);
}

void AppendSearchPath(const PathResult& path, v1::PlanResponse* response) {
  for (const Eigen::Vector3d& point : path.points_m) ToProto(point, response->add_search_path_m());
}

void ToProto(const MapGeometryData& g, v1::MapGeometry* m) {
  m->set_resolution_m(g.resolution_m);
  m->set_stride(static_cast<std::uint32_t>(g.stride));
  m->set_cell_size_m(g.resolution_m * g.stride);
  m->mutable_origin_m()->set_x(g.origin_m.x());
  m->mutable_origin_m()->set_y(g.origin_m.y());
  m->set_nx(static_cast<std::uint32_t>(g.nx));
  m->set_ny(static_cast<std::uint32_t>(g.ny));
  m->set_max_levels(static_cast<std::uint32_t>(g.max_levels));
  m->mutable_ground_cell()->Assign(g.ground_cell.begin(), g.ground_cell.end());
  m->mutable_ground_z_m()->Assign(g.ground_z_m.begin(), g.ground_z_m.end());
  m->mutable_ground_level()->Assign(g.ground_level.begin(), g.ground_level.end());
  m->mutable_ground_safety()->Assign(g.ground_safety.begin(), g.ground_safety.end());
  m->mutable_ground_component()->Assign(g.ground_component.begin(), g.ground_component.end());
  m->mutable_obstacle_cell()->Assign(g.obstacle_cell.begin(), g.obstacle_cell.end());
  m->mutable_obstacle_z_m()->Assign(g.obstacle_z_m.begin(), g.obstacle_z_m.end());
  m->mutable_obstacle_level()->Assign(g.obstacle_level.begin(), g.obstacle_level.end());
}

void ToProto(const PlanStats& s, v1::PlanStats* m) {
  m->set_length_m(s.length_m);
  m->set_duration_s(s.duration_s);
  m->set_mean_curvature_per_m(s.mean_curvature_per_m);
  m->set_max_speed_horizontal_mps(s.max_speed_horizontal_mps);
  m->set_max_speed_vertical_mps(s.max_speed_vertical_mps);
  m->set_max_accel_horizontal_mps2(s.max_accel_horizontal_mps2);
  m->set_max_accel_vertical_mps2(s.max_accel_vertical_mps2);
  m->set_min_obstacle_distance_m(s.min_obstacle_distance_m);
  m->set_max_ground_offset_m(s.max_ground_offset_m);
  m->set_max_tilt_rad(s.max_tilt_rad);
  m->set_min_body_height_m(s.min_body_height_m);
  if (std::isfinite(s.min_headroom_m)) m->set_min_headroom_m(s.min_headroom_m);
  m->set_pieces(s.pieces);
  m->set_search_expansions(s.search_expansions);
  m->set_optimizer_iterations(s.optimizer_iterations);
  m->set_optimizer_attempts(s.optimizer_attempts);
  m->set_verified_samples(s.verified_samples);
  m->set_time_stretch(s.time_stretch);
  m->set_warm_started(s.warm_started);
  m->set_fallback(s.fallback);
  m->set_fallback_reason(s.fallback_reason);
  m->set_limiting_bound(s.limiting_bound);
  m->set_limiting_bound_fraction(s.limiting_bound_fraction);
  v1::PlanTimings* t = m->mutable_timings();
  t->set_graph_s(s.timings.graph_s);
  t->set_snap_s(s.timings.snap_s);
  t->set_search_s(s.timings.search_s);
  t->set_optimize_s(s.timings.optimize_s);
  t->set_verify_s(s.timings.verify_s);
  t->set_total_s(s.timings.total_s);
}

ServiceStatus AppendSamples(const Trajectory& trajectory, double dt_s, int max_samples,
                            v1::PlanResponse* response) {
  const double total_s = trajectory.TotalDuration();
  if (trajectory.pieces.empty()) return OkStatus();
  // Samples at 0, dt, 2 dt, ... below the end, then the end itself.
  const double steps = std::ceil(total_s / dt_s - 1e-9);
  if (!(steps + 1 <= max_samples)) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("options.sample_dt_s = {:g} gives more than {} samples over the "
                                 "trajectory's {:g} s: use at least {:g} s",
                                 dt_s, max_samples, total_s, total_s / (max_samples - 1)))
        .Blame("options.sample_dt_s");
  }
  const auto count = static_cast<int>(steps) + 1;
  TrajectoryCursor cursor(trajectory);
  for (int i = 0; i < count; ++i) {
    const double t = std::min(i * dt_s, total_s);
    const StateVector p = cursor.Position(t);
    const StateVector v = cursor.Velocity(t);
    const StateVector a = cursor.Acceleration(t);
    v1::TrajectorySample* sample = response->add_samples();
    sample->set_time_s(t);
    ToProto(Eigen::Vector3d(p.head<3>()), sample->mutable_position_m());
    ToProto(Eigen::Vector3d(v.head<3>()), sample->mutable_velocity_mps());
    ToProto(Eigen::Vector3d(a.head<3>()), sample->mutable_acceleration_mps2());
    if (trajectory.dimension == 4) sample->set_body_height_m(p(3));
  }
  return OkStatus();
}

}  // namespace strata::server
