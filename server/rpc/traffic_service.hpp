#pragma once
/// strata.v1.TrafficService: the robots' reservations on each map (traffic/
/// reservation_schedule.hpp), committed, renewed, released and listed over gRPC.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>

#include <grpcpp/grpcpp.h>

#include "maps/map_registry.hpp"
#include "rpc/auth.hpp"
#include "rpc/planning_slots.hpp"
#include "rpc/rpc_boundary.hpp"
#include "strata/v1/traffic_service.grpc.pb.h"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

/// Most WatchSchedule streams a server serves at once: each holds one of gRPC's threads.
inline constexpr int kMaxWatches = 64;

class TrafficServiceImpl final : public v1::TrafficService::Service {
 public:
  /// `registry`, `schedule`, `slots` (where a trajectory to reserve is checked on the map,
  /// beside the plans) and `tokens` (null: no tokens) must outlive the service.
  TrafficServiceImpl(const MapRegistry* registry, ReservationSchedule* schedule,
                     PlanningSlots* slots, const TokenTable* tokens);

  /// The calls' work, without gRPC (`call` says who asks).
  ServiceStatus Reserve(const v1::ReserveTrajectoryRequest& request, const CallControl& call,
                        v1::Reservation* response);
  ServiceStatus Release(const v1::ReleaseReservationRequest& request, const CallControl& call,
                        v1::ReleaseReservationResponse* response);
  ServiceStatus Renew(const v1::RenewReservationRequest& request, const CallControl& call,
                      v1::Reservation* response);
  ServiceStatus List(const v1::ListReservationsRequest& request,
                     v1::ListReservationsResponse* response);
  ServiceStatus Report(const v1::ReportProgressRequest& request, const CallControl& call,
                       v1::ReportProgressResponse* response);
  /// WatchSchedule's work: `write` sends one change (false: the stream is broken).
  ServiceStatus Watch(const v1::WatchScheduleRequest& request, const CallControl& call,
                      const std::function<bool(const v1::ScheduleChange&)>& write);

  grpc::Status ReserveTrajectory(grpc::ServerContext* context,
                                 const v1::ReserveTrajectoryRequest* request,
                                 v1::Reservation* response) override;
  grpc::Status ReleaseReservation(grpc::ServerContext* context,
                                  const v1::ReleaseReservationRequest* request,
                                  v1::ReleaseReservationResponse* response) override;
  grpc::Status RenewReservation(grpc::ServerContext* context,
                                const v1::RenewReservationRequest* request,
                                v1::Reservation* response) override;
  grpc::Status ListReservations(grpc::ServerContext* context,
                                const v1::ListReservationsRequest* request,
                                v1::ListReservationsResponse* response) override;
  grpc::Status ReportProgress(grpc::ServerContext* context,
                              const v1::ReportProgressRequest* request,
                              v1::ReportProgressResponse* response) override;
  grpc::Status WatchSchedule(grpc::ServerContext* context, const v1::WatchScheduleRequest* request,
                             grpc::ServerWriter<v1::ScheduleChange>* writer) override;

 private:
  // Sends REPLAN_NEEDED for each of `reservations` (by robot) that is not safe on the map's
  // current version, once per reservation revision and version (`checked` remembers them).
  // False when the stream is broken.
  bool SendReplansNeeded(const std::string& map_id,
                         const std::map<std::string, Reservation>& reservations,
                         std::uint64_t revision,
                         std::map<std::string, std::pair<std::uint64_t, std::string>>* checked,
                         const std::function<bool(const v1::ScheduleChange&)>& write) const;
  // INVALID_ARGUMENT blaming "trajectory" unless `motion` (a trajectory to reserve) is safe on
  // the map version `request` names: with a profile, as Plan verifies its own; with a body
  // alone, the map's rules at samples (FirstUnsafeOnMap). Run in a planning slot. Sets
  // *version to the version checked.
  ServiceStatus CheckOnMap(const v1::ReserveTrajectoryRequest& request, const FleetMotion& motion,
                           const CallControl& call, std::string* version) const;
  // NOT_FOUND MAP_NOT_FOUND unless the registry holds `map_id`; its current version.
  Result<std::string> CurrentVersion(const std::string& map_id) const;
  RpcService Rpc() const { return {v1::TrafficService::service_full_name(), tokens_}; }

  const MapRegistry* registry_;
  ReservationSchedule* schedule_;
  PlanningSlots* slots_;
  const TokenTable* tokens_;
  std::atomic<int> watches_{0};  // WatchSchedule streams open, at most kMaxWatches.
};

}  // namespace strata::server
