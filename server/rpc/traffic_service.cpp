#include "rpc/traffic_service.hpp"

#include <algorithm>
#include <map>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "common/map_id.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "strata/fleet/map_change.hpp"
#include "strata/planner.hpp"
#include "strata/planning/robot_profile.hpp"

namespace strata::server {
namespace {

std::optional<double> Optional(bool has, double value) {
  return has ? std::optional<double>(value) : std::nullopt;
}

// The body of ReserveTrajectory's robot: a built-in profile's, or the one given.
Result<FleetBody> BodyOf(const v1::ReserveTrajectoryRequest& request) {
  switch (request.robot_case()) {
    case v1::ReserveTrajectoryRequest::kProfileName: {
      Expected<RobotProfile> profile = BuiltinProfile(request.profile_name());
      if (!profile) return ServiceError::FromPlanner(profile.error(), "profile_name");
      return FleetBody::FromProfile(profile.value());
    }
    case v1::ReserveTrajectoryRequest::kBody: return FromProto(request.body(), "body");
    default:
      return MakeError(ErrorCode::kInvalidInput, "the robot is missing: set profile_name or body")
          .Blame("robot");
  }
}

}  // namespace

TrafficServiceImpl::TrafficServiceImpl(const MapRegistry* registry, ReservationSchedule* schedule,
                                       PlanningSlots* slots, const TokenTable* tokens)
    : registry_(registry), schedule_(schedule), slots_(slots), tokens_(tokens) {}

ServiceStatus TrafficServiceImpl::CheckOnMap(const v1::ReserveTrajectoryRequest& request,
                                             const FleetMotion& motion, const CallControl& call,
                                             std::string* version) const {
  Result<ActiveMap> map = registry_->GetActive(request.map_id(), request.map_version());
  if (!map.ok()) return std::move(map).error();
  *version = map.value().version;
  const PlanningMap& planning_map = *map.value().map;
  const auto unsafe = [&](const std::string& why) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("trajectory is not safe on map {} version {}: {}; plan it on "
                                 "this version (Plan), or correct it",
                                 request.map_id(), *version, why))
        .Blame("trajectory");
  };
  return slots_->Run(
      call, [&](const std::function<bool()>& should_stop, double /*queue_s*/) -> ServiceStatus {
        if (request.robot_case() == v1::ReserveTrajectoryRequest::kProfileName) {
          Expected<RobotProfile> profile = BuiltinProfile(request.profile_name());
          if (!profile) return ServiceError::FromPlanner(profile.error(), "profile_name");
          Status safe =
              VerifyOnMap(planning_map, profile.value(), motion.trajectory, {}, should_stop);
          if (safe) return OkStatus();
          if (safe.error().code == ErrorCode::kOptimizationFailed)
            return unsafe(safe.error().message);
          return ServiceError::FromPlanner(safe.error(), "trajectory");
        }
        // A body alone holds no limits: the map's rules are checked where the body goes.
        const std::optional<UnsafeMotion> first =
            FirstUnsafeOnMap(planning_map, motion, motion.start_ns);
        if (!first) return OkStatus();
        return unsafe(fmt::format("{:.3f} s after its start, at ({:.2f}, {:.2f}, {:.2f}): {}",
                                  SecondsBetween(motion.start_ns, first->time_ns),
                                  first->position_m.x(), first->position_m.y(),
                                  first->position_m.z(), first->reason));
      });
}

Result<std::string> TrafficServiceImpl::CurrentVersion(const std::string& map_id) const {
  if (ServiceStatus given = RequireMapId(map_id); !given.ok()) return std::move(given).error();
  Result<MapSnapshot> map = registry_->Get(map_id);
  if (!map.ok()) return std::move(map).error();
  return map.value().version;
}

ServiceStatus TrafficServiceImpl::Reserve(const v1::ReserveTrajectoryRequest& request,
                                          const CallControl& call, v1::Reservation* response) {
  if (Result<std::string> map = CurrentVersion(request.map_id()); !map.ok()) {
    return std::move(map).error();
  }
  const ScheduleLimits& limits = schedule_->limits();
  if (!request.has_start_time()) {
    return MakeError(ErrorCode::kInvalidInput, "start_time is required").Blame("start_time");
  }
  Result<std::int64_t> start_ns = FromProto(request.start_time(), "start_time");
  if (!start_ns.ok()) return std::move(start_ns).error();
  const double lease_s = request.has_lease_s() ? request.lease_s() : limits.default_lease_s;
  if (ServiceStatus ok =
          schedule_->CheckRequest(request.robot_id(), "robot_id", start_ns.value(), lease_s);
      !ok.ok()) {
    return std::move(ok).error();
  }
  if (!request.has_trajectory()) {
    return MakeError(ErrorCode::kInvalidInput, "trajectory is required").Blame("trajectory");
  }
  Result<Trajectory> trajectory = FromProto(request.trajectory());
  if (!trajectory.ok()) return std::move(trajectory).error();
  Result<FleetBody> body = BodyOf(request);
  if (!body.ok()) return std::move(body).error();
  Result<SeparationRule> rule = SeparationFrom(
      Optional(request.has_separation_m(), request.separation_m()), limits, "separation_m");
  if (!rule.ok()) return std::move(rule).error();

  Reservation reservation;
  reservation.map_id = request.map_id();
  reservation.reserved.robot_id = request.robot_id();
  FleetMotion& motion = reservation.reserved.motion;
  motion.start_ns = start_ns.value();
  motion.trajectory = std::move(trajectory).value();
  motion.body = body.value();
  motion.end_ns = std::max(AddSeconds(schedule_->NowNs(), lease_s), motion.ArrivalNs());
  motion.separation_m = rule.value().separation_m;
  if (Status valid = motion.Validate("trajectory"); !valid) {
    return ServiceError::FromPlanner(valid.error(), valid.error().field);
  }
  if (ServiceStatus safe = CheckOnMap(request, motion, call, &reservation.map_version);
      !safe.ok()) {
    return safe;
  }
  Result<Reservation> committed = schedule_->Commit(std::move(reservation), rule.value(),
                                                    CallerOf(tokens_, call.authorization));
  if (!committed.ok()) return std::move(committed).error();
  ToProto(committed.value(), response);
  return OkStatus();
}

ServiceStatus TrafficServiceImpl::Release(const v1::ReleaseReservationRequest& request,
                                          const CallControl& call,
                                          v1::ReleaseReservationResponse* response) {
  if (Result<std::string> map = CurrentVersion(request.map_id()); !map.ok()) {
    return std::move(map).error();
  }
  Result<std::uint64_t> revision = schedule_->Release(request.map_id(), request.robot_id(),
                                                      CallerOf(tokens_, call.authorization));
  if (!revision.ok()) return std::move(revision).error();
  response->set_revision(revision.value());
  return OkStatus();
}

ServiceStatus TrafficServiceImpl::Renew(const v1::RenewReservationRequest& request,
                                        const CallControl& call, v1::Reservation* response) {
  if (Result<std::string> map = CurrentVersion(request.map_id()); !map.ok()) {
    return std::move(map).error();
  }
  const ScheduleLimits& limits = schedule_->limits();
  const double lease_s = request.has_lease_s() ? request.lease_s() : limits.default_lease_s;
  if (ServiceStatus lease = schedule_->CheckLease(lease_s); !lease.ok()) {
    return std::move(lease).error().Blame("lease_s");
  }
  Result<SeparationRule> rule = SeparationFrom(
      Optional(request.has_separation_m(), request.separation_m()), limits, "separation_m");
  if (!rule.ok()) return std::move(rule).error();
  Result<Reservation> renewed =
      schedule_->Renew(request.map_id(), request.robot_id(), lease_s, rule.value(),
                       CallerOf(tokens_, call.authorization));
  if (!renewed.ok()) return std::move(renewed).error();
  ToProto(renewed.value(), response);
  return OkStatus();
}

ServiceStatus TrafficServiceImpl::List(const v1::ListReservationsRequest& request,
                                       v1::ListReservationsResponse* response) {
  Result<std::string> current = CurrentVersion(request.map_id());
  if (!current.ok()) return std::move(current).error();
  std::int64_t from_ns = INT64_MIN, to_ns = INT64_MAX;
  if (request.has_from_time()) {
    Result<std::int64_t> from = FromProto(request.from_time(), "from_time");
    if (!from.ok()) return std::move(from).error();
    from_ns = from.value();
  }
  if (request.has_to_time()) {
    Result<std::int64_t> to = FromProto(request.to_time(), "to_time");
    if (!to.ok()) return std::move(to).error();
    to_ns = to.value();
  }
  const ReservationSchedule::Listing listing = schedule_->List(request.map_id(), from_ns, to_ns);
  for (const Reservation& reservation : listing.reservations) {
    ToProto(reservation, response->add_reservations());
  }
  response->set_revision(listing.revision);
  response->set_separation_m(schedule_->limits().default_separation_m);
  return OkStatus();
}

ServiceStatus TrafficServiceImpl::Report(const v1::ReportProgressRequest& request,
                                         const CallControl& call,
                                         v1::ReportProgressResponse* response) {
  if (Result<std::string> map = CurrentVersion(request.map_id()); !map.ok()) {
    return std::move(map).error();
  }
  Result<ReservationSchedule::Moved> moved =
      schedule_->Shift(request.map_id(), request.robot_id(), request.delay_s(),
                       CallerOf(tokens_, call.authorization));
  if (!moved.ok()) return std::move(moved).error();
  ToProto(moved.value().reservation, response->mutable_reservation());
  for (const ReservationSchedule::Meeting& meeting : moved.value().meetings) {
    v1::ReservationMeeting* out = response->add_meetings();
    out->set_robot_id(meeting.robot_id);
    ToProto(meeting.conflict.time_ns, out->mutable_time());
    const Eigen::Vector3d& where = meeting.conflict.point_a;
    out->mutable_position_m()->set_x(where.x());
    out->mutable_position_m()->set_y(where.y());
    out->mutable_position_m()->set_z(where.z());
  }
  return OkStatus();
}

ServiceStatus TrafficServiceImpl::Watch(
    const v1::WatchScheduleRequest& request, const CallControl& call,
    const std::function<bool(const v1::ScheduleChange&)>& write) {
  const std::string& map_id = request.map_id();
  if (Result<std::string> map = CurrentVersion(map_id); !map.ok()) return std::move(map).error();
  if (++watches_ > kMaxWatches) {
    --watches_;
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("this server already serves {} schedule watches: close one, or "
                                 "watch through another replica",
                                 kMaxWatches));
  }
  struct Release {
    std::atomic<int>& count;
    ~Release() { --count; }
  } release{watches_};
  // Each robot's reservation as last sent: the next listing is compared with it, so a slow
  // client gets every robot's latest state and never a backlog.
  std::map<std::string, Reservation> sent;
  std::uint64_t revision = 0;
  // The map version each robot's reservation (at its revision) was last checked on.
  std::map<std::string, std::pair<std::uint64_t, std::string>> checked;
  for (bool first = true;; first = false) {
    const ReservationSchedule::Listing listing = schedule_->List(map_id);
    if (first || listing.revision != revision) {
      std::map<std::string, Reservation> now;
      for (const Reservation& r : listing.reservations) now.emplace(r.reserved.robot_id, r);
      const std::int64_t now_ns = schedule_->NowNs();
      for (const auto& [robot, before] : sent) {
        if (now.contains(robot)) continue;
        v1::ScheduleChange change;
        change.set_kind(before.reserved.motion.end_ns < now_ns ? v1::ScheduleChange::EXPIRED
                                                               : v1::ScheduleChange::RELEASED);
        change.set_robot_id(robot);
        change.set_revision(listing.revision);
        if (!write(change)) return OkStatus();  // The client has gone.
      }
      for (const auto& [robot, reservation] : now) {
        const auto before = sent.find(robot);
        if (before != sent.end() && before->second.revision == reservation.revision) continue;
        v1::ScheduleChange change;
        change.set_kind(v1::ScheduleChange::RESERVED);
        change.set_robot_id(robot);
        ToProto(reservation, change.mutable_reservation());
        change.set_revision(listing.revision);
        if (!write(change)) return OkStatus();
      }
      sent = std::move(now);
      revision = listing.revision;
    }
    if (!SendReplansNeeded(map_id, sent, listing.revision, &checked, write)) return OkStatus();
    if (call.cancelled && call.cancelled()) return OkStatus();
    if (schedule_->closed()) {
      return MakeError(ServiceErrorCode::kShuttingDown,
                       "the server is shutting down: watch again through another replica");
    }
    if (!registry_->Get(map_id).ok()) {
      return MakeError(ServiceErrorCode::kMapNotFound,
                       fmt::format("map {} was deleted, and its schedule with it", map_id));
    }
    if (call.LeftSeconds() <= 0) {
      return MakeError(ErrorCode::kDeadlineExceeded, "the watch ran until its deadline");
    }
    // Wake on a change, or within a second to collect expired leases and see a cancellation.
    schedule_->WaitForChange(
        map_id, revision,
        std::min(call.deadline, std::chrono::steady_clock::now() + std::chrono::seconds(1)));
  }
}

bool TrafficServiceImpl::SendReplansNeeded(
    const std::string& map_id, const std::map<std::string, Reservation>& reservations,
    std::uint64_t revision, std::map<std::string, std::pair<std::uint64_t, std::string>>* checked,
    const std::function<bool(const v1::ScheduleChange&)>& write) const {
  std::erase_if(*checked, [&](const auto& entry) { return !reservations.contains(entry.first); });
  if (reservations.empty()) return true;
  const Result<ActiveMap> current = registry_->GetActive(map_id);
  if (!current.ok()) return true;  // Deleted or unreadable: the watch's loop says so.
  const std::int64_t now_ns = schedule_->NowNs();
  for (const auto& [robot, reservation] : reservations) {
    std::pair<std::uint64_t, std::string> key{reservation.revision, current.value().version};
    const auto it = checked->find(robot);
    if (it != checked->end() && it->second == key) continue;
    (*checked)[robot] = std::move(key);
    // Verified on that version when it was planned.
    if (reservation.map_version == current.value().version) continue;
    const std::optional<UnsafeMotion> unsafe =
        FirstUnsafeOnMap(*current.value().map, reservation.reserved.motion, now_ns);
    if (!unsafe) continue;
    v1::ScheduleChange change;
    change.set_kind(v1::ScheduleChange::REPLAN_NEEDED);
    change.set_robot_id(robot);
    ToProto(reservation, change.mutable_reservation());
    change.set_revision(revision);
    v1::ReplanNeeded* replan = change.mutable_replan();
    replan->set_map_version(current.value().version);
    ToProto(unsafe->time_ns, replan->mutable_time());
    replan->mutable_position_m()->set_x(unsafe->position_m.x());
    replan->mutable_position_m()->set_y(unsafe->position_m.y());
    replan->mutable_position_m()->set_z(unsafe->position_m.z());
    replan->set_reason(unsafe->reason);
    if (!write(change)) return false;
  }
  return true;
}

grpc::Status TrafficServiceImpl::ReserveTrajectory(grpc::ServerContext* context,
                                                   const v1::ReserveTrajectoryRequest* request,
                                                   v1::Reservation* response) {
  return RunRpc(Rpc(), "ReserveTrajectory", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.fields.emplace_back("robot", BoundedText(request->robot_id(), 64));
    return Reserve(*request, CallControlOf(*context), response);
  });
}

grpc::Status TrafficServiceImpl::ReleaseReservation(grpc::ServerContext* context,
                                                    const v1::ReleaseReservationRequest* request,
                                                    v1::ReleaseReservationResponse* response) {
  return RunRpc(Rpc(), "ReleaseReservation", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.fields.emplace_back("robot", BoundedText(request->robot_id(), 64));
    return Release(*request, CallControlOf(*context), response);
  });
}

grpc::Status TrafficServiceImpl::RenewReservation(grpc::ServerContext* context,
                                                  const v1::RenewReservationRequest* request,
                                                  v1::Reservation* response) {
  return RunRpc(Rpc(), "RenewReservation", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.fields.emplace_back("robot", BoundedText(request->robot_id(), 64));
    return Renew(*request, CallControlOf(*context), response);
  });
}

grpc::Status TrafficServiceImpl::ReportProgress(grpc::ServerContext* context,
                                                const v1::ReportProgressRequest* request,
                                                v1::ReportProgressResponse* response) {
  return RunRpc(Rpc(), "ReportProgress", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.fields.emplace_back("robot", BoundedText(request->robot_id(), 64));
    log.fields.emplace_back("delay_s", fmt::format("{:.3f}", request->delay_s()));
    return Report(*request, CallControlOf(*context), response);
  });
}

grpc::Status TrafficServiceImpl::WatchSchedule(grpc::ServerContext* context,
                                               const v1::WatchScheduleRequest* request,
                                               grpc::ServerWriter<v1::ScheduleChange>* writer) {
  return RunRpc(Rpc(), "WatchSchedule", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    return Watch(*request, CallControlOf(*context),
                 [writer](const v1::ScheduleChange& change) { return writer->Write(change); });
  });
}

grpc::Status TrafficServiceImpl::ListReservations(grpc::ServerContext* context,
                                                  const v1::ListReservationsRequest* request,
                                                  v1::ListReservationsResponse* response) {
  return RunRpc(Rpc(), "ListReservations", *context, [&](CallLog& log) -> ServiceStatus {
    log.map_id = request->map_id();
    log.quiet_on_success = true;
    return List(*request, response);
  });
}

}  // namespace strata::server
