// `strata reservations list|watch|renew|report|release`: the robots' reservations on a map
// (TrafficService).
#include <fmt/format.h>

#include "commands.hpp"
#include "connection.hpp"
#include "output.hpp"
#include "strata/v1/traffic_service.grpc.pb.h"

namespace strata::cli {
namespace {

struct RobotFlags {
  std::string map;
  std::string robot_id;
  std::optional<double> lease_s;
  double delay_s = 0;
};

std::unique_ptr<v1::TrafficService::Stub> Stub(const Context& ctx) {
  return v1::TrafficService::NewStub(OpenChannel(ctx));
}

void PrintReservation(std::ostream& out, const v1::Reservation& r) {
  out << fmt::format("{:<17} ", r.robot_id()) << FormatTime(r.start_time()) << "  "
      << FormatTime(r.expiry_time())
      << fmt::format("  {:>6}  {:>10.1f}  {:>12.2f}  ", r.trajectory().pieces_size(),
                     r.trajectory().duration_s(), r.separation_m())
      << r.revision() << "\n";
}

int List(const Context& ctx, const std::string& map) {
  v1::ListReservationsRequest request;
  request.set_map_id(map);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::ListReservationsResponse response;
  const grpc::Status status = Stub(ctx)->ListReservations(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "ListReservations", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
    return kExitOk;
  }
  std::ostream& out = *ctx.out;
  out << "map " << map << ", schedule revision " << response.revision() << ", "
      << response.reservations_size() << " reservation(s)\n";
  if (response.reservations_size() == 0) return kExitOk;
  out << "ROBOT             START                     EXPIRY                    PIECES  "
         "DURATION_S  SEPARATION_M  REVISION\n";
  for (const v1::Reservation& r : response.reservations()) PrintReservation(out, r);
  return kExitOk;
}

int Renew(const Context& ctx, const RobotFlags& flags) {
  v1::RenewReservationRequest request;
  request.set_map_id(flags.map);
  request.set_robot_id(flags.robot_id);
  if (flags.lease_s) request.set_lease_s(*flags.lease_s);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::Reservation response;
  const grpc::Status status = Stub(ctx)->RenewReservation(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "RenewReservation", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
  } else {
    *ctx.out << "robot " << flags.robot_id << " holds its reservation on map " << flags.map
             << " until " << FormatTime(response.expiry_time()) << "\n";
  }
  return kExitOk;
}

int Release(const Context& ctx, const RobotFlags& flags) {
  v1::ReleaseReservationRequest request;
  request.set_map_id(flags.map);
  request.set_robot_id(flags.robot_id);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::ReleaseReservationResponse response;
  const grpc::Status status = Stub(ctx)->ReleaseReservation(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "ReleaseReservation", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
  } else {
    *ctx.out << "released robot " << flags.robot_id << "'s reservation on map " << flags.map
             << " (schedule revision " << response.revision() << ")\n";
  }
  return kExitOk;
}

int Report(const Context& ctx, const RobotFlags& flags) {
  v1::ReportProgressRequest request;
  request.set_map_id(flags.map);
  request.set_robot_id(flags.robot_id);
  request.set_delay_s(flags.delay_s);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::ReportProgressResponse response;
  const grpc::Status status = Stub(ctx)->ReportProgress(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "ReportProgress", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
    return kExitOk;
  }
  std::ostream& out = *ctx.out;
  out << "robot " << flags.robot_id << "'s reservation now starts "
      << FormatTime(response.reservation().start_time()) << "; it meets "
      << response.meetings_size() << " other robot(s)\n";
  for (const v1::ReservationMeeting& meeting : response.meetings()) {
    out << "  " << meeting.robot_id() << " at " << FormatTime(meeting.time()) << ", "
        << FormatVector(meeting.position_m()) << " m\n";
  }
  return kExitOk;
}

// Prints each change as it comes, until the deadline (--deadline), which ends it normally.
int Watch(const Context& ctx, const std::string& map) {
  v1::WatchScheduleRequest request;
  request.set_map_id(map);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  auto stream = Stub(ctx)->WatchSchedule(&call, request);
  v1::ScheduleChange change;
  while (stream->Read(&change)) {
    if (ctx.json) {
      *ctx.out << ToJsonLine(change);
    } else {
      *ctx.out << "revision " << change.revision() << ": robot " << change.robot_id() << " "
               << v1::ScheduleChange::Kind_Name(change.kind());
      if (change.has_reservation()) {
        *ctx.out << " from " << FormatTime(change.reservation().start_time()) << " until "
                 << FormatTime(change.reservation().expiry_time());
        if (!change.reservation().replanned_for().empty()) {
          *ctx.out << ", replanned to let robot " << change.reservation().replanned_for()
                   << " pass";
        }
      }
      *ctx.out << "\n";
    }
    ctx.out->flush();
  }
  const grpc::Status status = stream->Finish();
  if (status.ok() || status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) return kExitOk;
  return ReportRpcError(ctx, "WatchSchedule", status);
}

}  // namespace

void AddReservationsCommands(CLI::App& app, const Context& ctx, Command* run) {
  CLI::App* reservations = app.add_subcommand(
      "reservations", "the robots' reserved trajectories on a map: list, renew, release");

  auto [list, list_map] =
      AddCommand<std::string>(*reservations, "list", "ListReservations: every live one, by robot",
                              run, [&ctx](const std::string& map) { return List(ctx, map); });
  list->add_option("--map", *list_map, "map id")->type_name("ID")->required();

  auto [watch, watch_map] = AddCommand<std::string>(
      *reservations, "watch",
      "WatchSchedule: each change as it happens, until --deadline (then exit 0)", run,
      [&ctx](const std::string& map) { return Watch(ctx, map); });
  watch->add_option("--map", *watch_map, "map id")->type_name("ID")->required();

  auto [renew, renew_flags] = AddCommand<RobotFlags>(
      *reservations, "renew", "RenewReservation: hold the robot's goal longer", run,
      [&ctx](const RobotFlags& flags) { return Renew(ctx, flags); });
  auto [report, report_flags] = AddCommand<RobotFlags>(
      *reservations, "report", "ReportProgress: the robot is late (or early) on its reservation",
      run, [&ctx](const RobotFlags& flags) { return Report(ctx, flags); });
  auto [release, release_flags] = AddCommand<RobotFlags>(
      *reservations, "release", "ReleaseReservation: the robot no longer holds its goal", run,
      [&ctx](const RobotFlags& flags) { return Release(ctx, flags); });
  for (auto [command, flags] :
       {std::pair{renew, renew_flags.get()}, std::pair{report, report_flags.get()},
        std::pair{release, release_flags.get()}}) {
    command->add_option("--map", flags->map, "map id")->type_name("ID")->required();
    command->add_option("--robot-id", flags->robot_id, "the robot")->type_name("ID")->required();
  }
  renew
      ->add_option("--lease", renew_flags->lease_s,
                   "the lease from now [s]; unset: the server's --default-lease-s")
      ->type_name("S")
      ->check(PositiveNumber());
  report->add_option("--delay", report_flags->delay_s, "how late the robot is [s]; < 0: early")
      ->type_name("S")
      ->required()
      ->check(FiniteNumber());
}

}  // namespace strata::cli
