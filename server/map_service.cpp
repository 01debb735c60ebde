#include "map_service.hpp"

#include <algorithm>
#include <optional>

#include "map_root.hpp"
#include "proto_convert.hpp"
#include "rpc_boundary.hpp"
#include "strata/scenes/scenes.hpp"
#include "upload_assembler.hpp"

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
      Result<std::filesystem::path> path =
          ResolveMapPath(map_root, request.file().path(), "file.path");
      if (!path.ok()) return std::move(path).error();
      return MapSource(FileMapSource{path.value(), request.file().path()});
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
  return RunRpc("CreateMap", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kAdmin); !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    if (!request->map_id().empty()) {
      if (ServiceStatus valid = MapRegistry::ValidateId(request->map_id()); !valid.ok()) {
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
  return RunRpc("UploadMap", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kAdmin); !allowed.ok()) {
      return allowed;
    }
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

grpc::Status MapServiceImpl::GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                                    v1::Map* response) {
  return RunRpc("GetMap", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    log.quiet_on_success = true;
    Result<MapSnapshot> map = registry_->Get(request->map_id());
    if (!map.ok()) return std::move(map).error().Blame("map_id");
    ToProto(map.value(), response);
    return OkStatus();
  });
}

grpc::Status MapServiceImpl::ListMaps(grpc::ServerContext* context,
                                      const v1::ListMapsRequest* request,
                                      v1::ListMapsResponse* response) {
  return RunRpc("ListMaps", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kPlanner);
        !allowed.ok()) {
      return allowed;
    }
    log.quiet_on_success = true;
    if (request->page_size() < 0 || request->page_size() > kMaxPageSize) {
      return MakeError(ErrorCode::kInvalidInput,
                       "page_size = " + std::to_string(request->page_size()) +
                           " is out of range: must be in [0, 1000] (0 means 100)")
          .Blame("page_size");
    }
    const int page_size = request->page_size() == 0 ? kDefaultPageSize : request->page_size();
    std::string after;
    if (!request->page_token().empty()) {
      const std::string& token = request->page_token();
      const bool well_formed = token.rfind(kPageTokenPrefix, 0) == 0 &&
                               MapRegistry::ValidateId(token.substr(kPageTokenPrefix.size())).ok();
      if (!well_formed) {
        return MakeError(ErrorCode::kInvalidInput,
                         "page_token is not one this server issued: pass next_page_token of "
                         "the previous response unchanged, or an empty token for the first "
                         "page")
            .Blame("page_token");
      }
      after = token.substr(kPageTokenPrefix.size());
    }
    const MapPage page = registry_->List(after, page_size);
    for (const MapSnapshot& map : page.maps) ToProto(map, response->add_maps());
    if (!page.last_id.empty()) {
      response->set_next_page_token(std::string(kPageTokenPrefix) + page.last_id);
    }
    return OkStatus();
  });
}

grpc::Status MapServiceImpl::DeleteMap(grpc::ServerContext* context,
                                       const v1::DeleteMapRequest* request,
                                       v1::DeleteMapResponse*) {
  return RunRpc("DeleteMap", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kAdmin); !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    ServiceStatus deleted = registry_->Delete(request->map_id());
    if (!deleted.ok()) return std::move(deleted).error().Blame("map_id");
    return OkStatus();
  });
}

grpc::Status MapServiceImpl::UpdateMap(grpc::ServerContext* context,
                                       const v1::UpdateMapRequest* request,
                                       v1::UpdateMapResponse* response) {
  return RunRpc("UpdateMap", [&](CallLog& log) -> ServiceStatus {
    if (ServiceStatus allowed = Authorize(*context, options_.tokens, Role::kAdmin); !allowed.ok()) {
      return allowed;
    }
    log.map_id = request->map_id();
    Result<ParsedMapEdits> parsed = MapEditsFromProto(*request);
    if (!parsed.ok()) return std::move(parsed).error();
    Result<MapUpdate> updated =
        registry_->Update(request->map_id(), request->base_version(), parsed.value().edits,
                          parsed.value().add_keep_out, request->clear_keep_out());
    if (!updated.ok()) return std::move(updated).error();
    const MapUpdate& update = updated.value();
    ToProto(update.map, response->mutable_map());
    v1::MapUpdateStats* stats = response->mutable_stats();
    stats->set_apply_s(update.apply_s);
    stats->set_reassess_s(update.reassess_s);
    stats->set_write_s(update.write_s);
    stats->set_total_s(update.total_s);
    stats->set_full_reassessment(update.full_reassessment);
    stats->set_full_reassessment_reason(update.full_reason);
    stats->set_reassessed_columns(update.reassessed_columns);
    log.fields.emplace_back("version", update.map.version);
    return OkStatus();
  });
}

}  // namespace strata::server
