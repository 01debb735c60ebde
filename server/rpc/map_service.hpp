#pragma once
/// strata.v1.MapService: adapts the map registry to gRPC.
#include <cstdint>
#include <filesystem>

#include <grpcpp/grpcpp.h>

#include "maps/map_registry.hpp"
#include "rpc/auth.hpp"
#include "rpc/planning_slots.hpp"
#include "rpc/rpc_boundary.hpp"
#include "strata/v1/map_service.grpc.pb.h"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

/// Set from ServerConfig (server/ops/flags.hpp), which holds the defaults and the flags.
struct MapServiceOptions {
  /// Canonical map root; empty disables file maps (--map-root).
  std::filesystem::path map_root;
  /// Most points one map may hold, uploaded or generated [-], > 0 (--max-points).
  std::size_t max_points = 0;
  /// Tokens the calls must carry (--auth-tokens); null lets every call through.
  const TokenTable* tokens = nullptr;
  /// The server's memory budget, in which uploads are counted as they arrive; may be null.
  MemoryBudget* memory_budget = nullptr;
  /// The planning slots, which GetMapGeometry with a robot takes as a plan does (building the
  /// robot's graph is a plan's first step). Required.
  PlanningSlots* planning_slots = nullptr;
  /// Largest response message [bytes] (--max-send-message-bytes): GetMapGeometry's max_bytes
  /// may not exceed it.
  std::uint64_t max_send_message_bytes = 0;
  /// The robots' reservations, which a deleted map's go with it; may be null.
  ReservationSchedule* reservations = nullptr;
};

/// GetMapGeometry's max_bytes when the request leaves it 0 [bytes] (capped by
/// --max-send-message-bytes), and the least a request may ask for.
inline constexpr std::uint64_t kDefaultGeometryBytes = std::uint64_t{4} << 20;
inline constexpr std::uint64_t kMinGeometryBytes = std::uint64_t{64} << 10;

/// GetMap's work, for every API (the gRPC handler, the web viewer's): the map's public view;
/// kMapNotFound blaming "map_id".
ServiceStatus GetMapFrom(const MapRegistry& registry, const v1::GetMapRequest& request,
                         v1::Map* response);
/// ListMaps' work, for every API; kInvalidInput blaming "page_size" or "page_token".
ServiceStatus ListMapsFrom(const MapRegistry& registry, const v1::ListMapsRequest& request,
                           v1::ListMapsResponse* response);

/// The MapSource of a CreateMapRequest: a file confined to `map_root`, or a scene with every
/// option resolved (seed kDefaultSceneSeed when the request has none, the scene's size and
/// spacing when it has none), refused when it would hold more than `max_points` points.
/// Errors blame request fields ("file.path", "scene.name", "scene.size_m", "scene.spacing_m",
/// "source"). The request's terrain
/// parameters are converted apart, by FromProto (proto_convert.hpp).
Result<MapSource> SourceFromRequest(const v1::CreateMapRequest& request,
                                    const std::filesystem::path& map_root, std::size_t max_points);

/// The latest time a handler may wait before answering, from the call's deadline: a little
/// before it (10% of the time left, at most 100 ms), so the answer still arrives.
std::chrono::steady_clock::time_point WaitDeadline(const grpc::ServerContext& context);

class MapServiceImpl final : public v1::MapService::Service {
 public:
  /// `registry` must outlive the service.
  MapServiceImpl(MapRegistry* registry, MapServiceOptions options);

  grpc::Status CreateMap(grpc::ServerContext* context, const v1::CreateMapRequest* request,
                         v1::Map* response) override;
  grpc::Status UploadMap(grpc::ServerContext* context,
                         grpc::ServerReader<v1::UploadMapRequest>* reader,
                         v1::Map* response) override;
  grpc::Status GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                      v1::Map* response) override;
  grpc::Status ListMaps(grpc::ServerContext* context, const v1::ListMapsRequest* request,
                        v1::ListMapsResponse* response) override;
  grpc::Status GetMapGeometry(grpc::ServerContext* context,
                              const v1::GetMapGeometryRequest* request,
                              v1::MapGeometry* response) override;
  grpc::Status DeleteMap(grpc::ServerContext* context, const v1::DeleteMapRequest* request,
                         v1::DeleteMapResponse* response) override;
  grpc::Status UpdateMap(grpc::ServerContext* context, const v1::UpdateMapRequest* request,
                         v1::UpdateMapResponse* response) override;

  /// GetMapGeometry's work, for every API: validates the request, then extracts the map's
  /// surfaces (ExtractMapGeometry) at the stride asked for, or at the smallest that fits
  /// max_bytes; with a robot, inside a planning slot (its graph is a plan's first step), within
  /// --max-plan-time-s and the call's deadline. The caller has authorised the call.
  ServiceStatus GetMapGeometry(const v1::GetMapGeometryRequest& request, const CallControl& call,
                               v1::MapGeometry* response) const;

 private:
  // Returns the new map, waiting for it when `wait` is set (see CreateMapRequest.wait).
  ServiceStatus Respond(grpc::ServerContext* context, const MapSnapshot& created, bool wait,
                        v1::Map* response);

  MapRegistry* registry_;
  // The service and its tokens, for the RPC boundary.
  RpcService Rpc() const { return {v1::MapService::service_full_name(), options_.tokens}; }

  MapServiceOptions options_;
};

}  // namespace strata::server
