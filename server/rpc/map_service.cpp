#include "rpc/map_service.hpp"

#include "common/map_id.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "maps/map_root.hpp"
#include "rpc/map_geometry.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/rpc_boundary.hpp"
#include "rpc/upload_assembler.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata::server {
namespace {

using SteadyClock = std::chrono::steady_clock;

constexpr int kDefaultPageSize = 100;
constexpr int kMaxPageSize = 1000;
constexpr std::string_view kPageTokenPrefix = "after:";

std::string JoinedSceneNames() {
  std::string names;
  for (const std::string& name : SceneNames()) names += (names.empty() ? "" : ", ") + name;
  return names;
}

}  // namespace

Result<MapSource> SourceFromRequest(const v1::CreateMapRequest& request,
                                    const std::filesystem::path& map_root, std::size_t max_points) {
  switch (request.source_case()) {
    case v1::CreateMapRequest::kFile: {
      Result<std::shared_ptr<const OpenedMapFile>> file =
          OpenMapFile(map_root, request.file().path(), "file.path");
      if (!file.ok()) return std::move(file).error();
      return MapSource(FileMapSource{std::move(file).value(), request.file().path()});
    }
    case v1::CreateMapRequest::kScene: {
      const std::vector<std::string> names = SceneNames();
      if (std::find(names.begin(), names.end(), request.scene().name()) == names.end()) {
        return MakeError(ErrorCode::kInvalidInput,
                         "unknown scene '" + request.scene().name().substr(0, 64) +
                             "': the built-in scenes are " + JoinedSceneNames())
            .Blame("scene.name");
      }
      const v1::SceneSource& scene = request.scene();
      SceneMapSource source{scene.name(), scene.has_seed() ? scene.seed() : kDefaultSceneSeed, {}};
      // Each option alone first, so that the error blames the field at fault.
      struct Option {
        std::optional<double> SceneOptions::*field;
        bool given;
        double value;
        const char* path;
      };
      for (const Option& o :
           {Option{&SceneOptions::size_m, scene.has_size_m(), scene.size_m(), "scene.size_m"},
            Option{&SceneOptions::spacing_m, scene.has_spacing_m(), scene.spacing_m(),
                   "scene.spacing_m"}}) {
        if (!o.given) continue;
        SceneOptions alone;
        alone.*o.field = o.value;
        source.options.*o.field = o.value;
        if (auto valid = ResolveSceneOptions(scene.name(), alone); !valid) {
          return ServiceError::FromPlanner(valid.error(), o.path);
        }
      }
      source.options = ResolveSceneOptions(scene.name(), source.options).value();
      if (Status fits = CheckScene(source.name, source.seed, source.options, max_points); !fits) {
        return ServiceError::FromPlanner(fits.error(), "scene.spacing_m");
      }
      return MapSource(std::move(source));
    }
    case v1::CreateMapRequest::SOURCE_NOT_SET: break;
  }
  return MakeError(ErrorCode::kInvalidInput,
                   "no source given: set file (a path under the server's map root) or scene "
                   "(one of " +
                       JoinedSceneNames() + ")")
      .Blame("source");
}

SteadyClock::time_point WaitDeadline(const grpc::ServerContext& context) {
  const auto deadline = context.deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) {
    return SteadyClock::time_point::max();
  }
  const auto left = std::chrono::duration_cast<SteadyClock::duration>(
      deadline - std::chrono::system_clock::now());
  const auto margin = std::min<SteadyClock::duration>(left / 10, std::chrono::milliseconds(100));
  return SteadyClock::now() + left - margin;
}

MapServiceImpl::MapServiceImpl(MapRegistry* registry, MapServiceOptions options)
    : registry_(registry), options_(std::move(options)) {}

ServiceStatus MapServiceImpl::Respond(grpc::ServerContext* context, const MapSnapshot& created,
                                      bool wait, v1::Map* response) {
  if (!wait) {
    ToProto(created, response);
    return OkStatus();
  }
  Result<MapSnapshot> done = registry_->WaitUntilDone(created.id, WaitDeadline(*context),
                                                      [context] { return context->IsCancelled(); });
  if (!done.ok()) return std::move(done).error();
  if (done->state == MapState::kFailed && done->failure.has_value()) {
    return *done->failure;
  }
  ToProto(done.value(), response);
  return OkStatus();
}

grpc::Status MapServiceImpl::CreateMap(grpc::ServerContext* context,
                                       const v1::CreateMapRequest* request, v1::Map* response) {
  return RunRpc(Rpc(), "CreateMap", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    if (!request->map_id().empty()) {
      if (ServiceStatus valid = ValidateMapId(request->map_id()); !valid.ok()) {
        return valid;
      }
    }
    Result<AssessmentConfig> config = FromProto(request->terrain(), "terrain");
    if (!config.ok()) return std::move(config).error();
    Result<MapSource> source = SourceFromRequest(*request, options_.map_root, options_.max_points);
    if (!source.ok()) return std::move(source).error();
    Result<MapSnapshot> created =
        registry_->Create(request->map_id(), std::move(source).value(), config.value(),
                          request->has_terrain() && request->terrain().ByteSizeLong() > 0);
    if (!created.ok()) return std::move(created).error();
    log.map_id = created->id;
    return Respond(context, created.value(), request->wait(), response);
  });
}

grpc::Status MapServiceImpl::UploadMap(grpc::ServerContext* context,
                                       grpc::ServerReader<v1::UploadMapRequest>* reader,
                                       v1::Map* response) {
  return RunRpc(Rpc(), "UploadMap", *context, [&](CallLog& log) -> ServiceStatus {
    UploadAssembler upload(options_.max_points, options_.memory_budget);
    v1::UploadMapRequest message;
    bool first = true;
    while (reader->Read(&message)) {
      if (ServiceStatus added = upload.Add(message); !added.ok()) return added;
      if (first) {
        first = false;
        log.map_id = upload.header().map_id();
        // Refuse a taken id before the client sends the whole cloud (Create checks again).
        const std::string& id = upload.header().map_id();
        if (Result<MapSnapshot> existing = registry_->Get(id);
            !id.empty() && existing.ok() && existing->state != MapState::kFailed) {
          return MakeError(ServiceErrorCode::kMapAlreadyExists,
                           "map '" + id +
                               "' already exists: delete it first or choose "
                               "another id")
              .With("map_id", id)
              .Blame("header.map_id");
        }
      }
    }
    // The stream broke off: gRPC has answered the client itself, and what we return is only
    // logged. From here the two causes look alike, so the log names both. (gRPC does not
    // always mark the call cancelled by the time Read fails: Finish's messages name the
    // limit too.)
    if (context->IsCancelled()) {
      return MakeError(ErrorCode::kCancelled,
                       "the upload broke off before its end: the client cancelled it, or gRPC "
                       "refused a message larger than --max-receive-message-bytes and answered "
                       "RESOURCE_EXHAUSTED (chunks hold at most 1 MiB)");
    }
    if (ServiceStatus finished = upload.Finish(); !finished.ok()) return finished;
    log.fields.emplace_back("points", std::to_string(upload.point_count()));
    const bool wait = upload.header().wait();
    const std::string id = upload.header().map_id();
    const AssessmentConfig config = upload.config();
    Result<MapSnapshot> created = registry_->Create(id, upload.TakeSource(), config);
    if (!created.ok()) return std::move(created).error();
    log.map_id = created->id;
    return Respond(context, created.value(), wait, response);
  });
}

ServiceStatus GetMapFrom(const MapRegistry& registry, const v1::GetMapRequest& request,
                         v1::Map* response) {
  Result<MapSnapshot> map = registry.Get(request.map_id());
  if (!map.ok()) return std::move(map).error().Blame("map_id");
  ToProto(map.value(), response);
  return OkStatus();
}

ServiceStatus ListMapsFrom(const MapRegistry& registry, const v1::ListMapsRequest& request,
                           v1::ListMapsResponse* response) {
  if (request.page_size() < 0 || request.page_size() > kMaxPageSize) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("page_size = {} is out of range: must be in [0, 1000] (0 means "
                                 "100)",
                                 request.page_size()))
        .Blame("page_size");
  }
  const int page_size = request.page_size() == 0 ? kDefaultPageSize : request.page_size();
  std::string after;
  if (!request.page_token().empty()) {
    const std::string& token = request.page_token();
    const bool well_formed = token.rfind(kPageTokenPrefix, 0) == 0 &&
                             ValidateMapId(token.substr(kPageTokenPrefix.size())).ok();
    if (!well_formed) {
      return MakeError(ErrorCode::kInvalidInput,
                       "page_token is not one this server issued: pass next_page_token of the "
                       "previous response unchanged, or an empty token for the first page")
          .Blame("page_token");
    }
    after = token.substr(kPageTokenPrefix.size());
  }
  const MapPage page = registry.List(after, page_size);
  for (const MapSnapshot& map : page.maps) ToProto(map, response->add_maps());
  if (!page.last_id.empty()) {
    response->set_next_page_token(std::string(kPageTokenPrefix) + page.last_id);
  }
  return OkStatus();
}

grpc::Status MapServiceImpl::GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                                    v1::Map* response) {
  return RunRpc(Rpc(), "GetMap", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.quiet_on_success = true;
    return GetMapFrom(*registry_, *request, response);
  });
}

grpc::Status MapServiceImpl::ListMaps(grpc::ServerContext* context,
                                      const v1::ListMapsRequest* request,
                                      v1::ListMapsResponse* response) {
  return RunRpc(Rpc(), "ListMaps", *context, [&](CallLog& log) -> ServiceStatus {
    log.quiet_on_success = true;
    return ListMapsFrom(*registry_, *request, response);
  });
}

ServiceStatus MapServiceImpl::GetMapGeometry(const v1::GetMapGeometryRequest& request,
                                             const CallControl& call,
                                             v1::MapGeometry* response) const {
  if (ServiceStatus given = RequireMapId(request.map_id()); !given.ok()) {
    return std::move(given).error();
  }
  const std::uint64_t cap = options_.max_send_message_bytes;
  if (request.max_bytes() != 0 &&
      (request.max_bytes() < kMinGeometryBytes || request.max_bytes() > cap)) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("max_bytes = {} is out of range: must be 0 (the default) or in "
                                 "[{}, {}] (--max-send-message-bytes)",
                                 request.max_bytes(), kMinGeometryBytes, cap))
        .Blame("max_bytes");
  }
  if (request.stride() > static_cast<std::uint32_t>(kMaxGeometryStride)) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("stride = {} is out of range: must be in [0, {}] (0 lets the "
                                 "server pick one that fits max_bytes)",
                                 request.stride(), kMaxGeometryStride))
        .Blame("stride");
  }
  const std::uint64_t max_bytes =
      request.max_bytes() != 0 ? request.max_bytes() : std::min(kDefaultGeometryBytes, cap);
  Result<std::optional<RobotProfile>> profile = ProfileFromRequest(request);
  if (!profile.ok()) return std::move(profile).error();
  Result<ActiveMap> active = registry_->GetActive(request.map_id(), request.map_version());
  if (!active.ok()) return std::move(active).error().With("map_id", request.map_id());
  const PlanningMap& map = *active.value().map;
  const std::optional<RobotProfile>& robot = profile.value();
  if (robot.has_value()) {
    if (Status fits = CheckProfileFitsMap(*robot, map.model().config()); !fits) {
      return ServiceError::FromPlanner(fits.error(),
                                       request.has_profile() ? "profile" : "profile_name");
    }
  }

  GeometryRequest geometry;
  geometry.include_safety = request.include_safety();
  // S' where the robot's reference point would be; without a robot, the default one's.
  geometry.safety_height_m = robot.has_value() ? robot->reference_height_m
                                               : BuiltinProfile("differential")->reference_height_m;
  // Bytes per surface in the binary encoding, a little above what they take (a cell index,
  // a height, a level; S' and a component when asked for), for the first stride.
  const double bytes_per_surface =
      10.0 + (geometry.include_safety ? 4.0 : 0.0) + (robot.has_value() ? 3.0 : 0.0);
  const auto extract = [&](const std::function<bool()>& should_stop) -> ServiceStatus {
    int stride = request.stride() != 0
                     ? static_cast<int>(request.stride())
                     : EstimateGeometryStride(map.model(), max_bytes, bytes_per_surface);
    while (true) {
      geometry.stride = stride;
      Expected<MapGeometryData> data = ExtractMapGeometry(map.model(), geometry, should_stop);
      if (!data) return ServiceError::FromPlanner(data.error(), data.error().field);
      response->Clear();
      ToProto(data.value(), response);
      response->set_map_id(request.map_id());
      response->set_map_version(active.value().version);
      if (geometry.include_safety) response->set_safety_height_m(geometry.safety_height_m);
      const std::size_t bytes = response->ByteSizeLong();
      if (bytes <= max_bytes) return OkStatus();
      // The stride that would fit were the surfaces spread evenly (at least one more).
      const int fits = std::min(
          kMaxGeometryStride,
          std::max(stride + 1, static_cast<int>(std::ceil(
                                   stride * std::sqrt(static_cast<double>(bytes) / max_bytes)))));
      if (request.stride() != 0 || stride == kMaxGeometryStride) {
        response->Clear();
        return MakeError(ErrorCode::kResourceExhausted,
                         fmt::format("the map's geometry at stride {} takes {} bytes, more than "
                                     "max_bytes {}: {}",
                                     stride, bytes, max_bytes,
                                     stride == kMaxGeometryStride
                                         ? std::string("allow a larger max_bytes")
                                         : fmt::format("ask for stride {} or more (0 lets the "
                                                       "server pick one that fits), or a larger "
                                                       "max_bytes (up to "
                                                       "--max-send-message-bytes)",
                                                       fits)))
            .Blame(request.stride() != 0 ? "stride" : "max_bytes");
      }
      stride = fits;
    }
  };
  if (!robot.has_value()) return extract(call.cancelled);

  // With a robot, its graph is a plan's first step: it takes a planning slot and the time a
  // plan may take.
  PlanningSlots& slots = *options_.planning_slots;
  return slots.Run(call, [&](const std::function<bool()>& should_stop, double) -> ServiceStatus {
    const double budget_s = std::min(slots.max_plan_time_s(), WorkSecondsLeft(call.LeftSeconds()));
    if (budget_s <= 0) return DeadlineLeavesNoTime(call.LeftSeconds());
    const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                   std::chrono::duration<double>(budget_s));
    const auto stop = [&] { return should_stop() || SteadyClock::now() > deadline; };
    const auto out_of_time = [&](const char* what) {
      return MakeError(ErrorCode::kDeadlineExceeded,
                       fmt::format("{} took longer than the {:.3f} s allowed (the smaller of "
                                   "--max-plan-time-s and the call's deadline)",
                                   what, budget_s));
    };
    Expected<std::shared_ptr<const SurfaceGraph>> graph = map.Graph(robot->Traversability(), stop);
    if (!graph) {
      if (!should_stop() && SteadyClock::now() > deadline) {
        return out_of_time("building the robot's traversability graph");
      }
      return ServiceError::FromPlanner(graph.error());
    }
    geometry.graph = graph.value().get();
    ServiceStatus extracted = extract(stop);
    if (!extracted.ok() && !should_stop() && SteadyClock::now() > deadline) {
      return out_of_time("extracting the map's geometry");
    }
    return extracted;
  });
}

grpc::Status MapServiceImpl::GetMapGeometry(grpc::ServerContext* context,
                                            const v1::GetMapGeometryRequest* request,
                                            v1::MapGeometry* response) {
  return RunRpc(Rpc(), "GetMapGeometry", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    ServiceStatus status = GetMapGeometry(*request, CallControlOf(*context), response);
    if (status.ok()) {
      log.fields.emplace_back("stride", std::to_string(response->stride()));
      log.fields.emplace_back(
          "surfaces", std::to_string(response->ground_z_m_size() + response->obstacle_z_m_size()));
    }
    return status;
  });
}

grpc::Status MapServiceImpl::DeleteMap(grpc::ServerContext* context,
                                       const v1::DeleteMapRequest* request,
                                       v1::DeleteMapResponse*) {
  return RunRpc(Rpc(), "DeleteMap", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    ServiceStatus deleted = registry_->Delete(request->map_id());
    if (!deleted.ok()) return std::move(deleted).error().Blame("map_id");
    if (options_.reservations != nullptr) options_.reservations->DropMap(request->map_id());
    return OkStatus();
  });
}

grpc::Status MapServiceImpl::UpdateMap(grpc::ServerContext* context,
                                       const v1::UpdateMapRequest* request,
                                       v1::UpdateMapResponse* response) {
  return RunRpc(Rpc(), "UpdateMap", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    Result<ParsedMapEdits> parsed = MapEditsFromProto(*request);
    if (!parsed.ok()) return std::move(parsed).error();
    ParsedMapEdits edits = std::move(parsed).value();
    MapEditRequest edit{request->map_id(), request->base_version(), std::move(edits.edits),
                        request->clear_keep_out(), std::move(edits.add_keep_out)};
    Result<MapUpdate> updated = registry_->Update(edit, CallControlOf(*context));
    if (!updated.ok()) return std::move(updated).error();
    const MapUpdate& update = updated.value();
    ToProto(update.map, response->mutable_map());
    v1::MapUpdateStats* stats = response->mutable_stats();
    stats->set_apply_s(update.edit.apply_s);
    stats->set_reassess_s(update.edit.reassess_s);
    stats->set_write_s(update.write_s);
    stats->set_total_s(update.total_s);
    stats->set_full_reassessment(update.edit.full_reassessment);
    stats->set_full_reassessment_reason(update.edit.full_reason);
    stats->set_reassessed_columns(update.edit.reassessed_columns);
    stats->set_load_s(update.load_s);
    stats->set_from_tiles(update.edit.from_tiles);
    stats->set_join_s(update.edit.join_s);
    stats->set_scan_points_outside_region(update.edit.scan_points_outside_region);
    stats->set_scan_points_thinned(update.edit.scan_points_thinned);
    stats->set_merged_updates(update.merged_updates);
    stats->set_graphs_s(update.graphs_s);
    stats->set_written_bytes(update.writes.bytes_written);
    stats->set_tiles_written(update.writes.written);
    stats->set_tiles_shared(update.writes.shared);
    log.fields.emplace_back("version", update.map.version);
    return OkStatus();
  });
}

}  // namespace strata::server
