#include "rpc/fleet_planning.hpp"

#include <algorithm>
#include <chrono>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"

namespace strata::server {
namespace {

// From when a plan's answer could be sent until a robot it replans takes its new trajectory
// [s]: the time for the robot to hear of it (WatchSchedule).
constexpr double kReplanNoticeS = 1.0;

}  // namespace

ServiceStatus PlanAmongReservations(const ActiveMap& map, const std::string& map_id,
                                    const ParsedPlanRequest& request, ReservationSchedule& schedule,
                                    const Caller& caller, const std::function<bool()>& should_stop,
                                    int max_samples, v1::PlanResponse* response,
                                    PlanTimings* timings) {
  const ParsedFleet& fleet = *request.fleet;
  const ScheduleLimits& limits = schedule.limits();
  const std::int64_t now_ns = schedule.NowNs();
  const double lease_s = fleet.lease_s.value_or(limits.default_lease_s);
  FleetPlanRequest planned_request;
  planned_request.plan = request.plan;
  planned_request.departure_ns = fleet.departure_ns.value_or(now_ns);
  planned_request.parked_until_ns = AddSeconds(now_ns, lease_s);
  if (ServiceStatus ok = schedule.CheckRequest(fleet.robot_id, "fleet.robot_id",
                                               planned_request.departure_ns, lease_s);
      !ok.ok()) {
    return ok;
  }
  Result<SeparationRule> rule = SeparationFrom(fleet.separation_m, limits, "fleet.separation_m");
  if (!rule.ok()) return std::move(rule).error();
  planned_request.fleet = fleet.options;
  planned_request.fleet.rule = rule.value();

  const auto start = std::chrono::steady_clock::now();
  const double budget_s = request.plan.options.time_budget_s;
  for (int attempt = 1;; ++attempt) {
    const ReservationSchedule::Traffic traffic = fleet.avoid_reservations
                                                     ? schedule.OthersOf(map_id, fleet.robot_id)
                                                     : ReservationSchedule::Traffic{};
    planned_request.others = traffic.others;
    // Only a plan that commits replans others: their new motions are committed with it.
    if (fleet.reserve) planned_request.replannable = traffic.replannable;
    const double spent_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    planned_request.plan.options.time_budget_s = budget_s - spent_s;
    if (planned_request.plan.options.time_budget_s <= 0) {
      return MakeError(ErrorCode::kDeadlineExceeded,
                       fmt::format("the plan's time budget of {:.3f} s ran out after {} "
                                   "attempts to commit it: other robots kept committing into its "
                                   "way; allow more time (options.time_budget_s or the call's "
                                   "deadline)",
                                   budget_s, attempt - 1));
    }
    if (!planned_request.replannable.empty()) {
      // A robot replanned takes its new trajectory at the notice: a second after this plan's
      // departure, and after the plan could be committed and sent out (CommitReplanning
      // refuses a notice already past).
      const std::int64_t notice_ns =
          std::max(AddSeconds(planned_request.departure_ns, kReplanNoticeS),
                   AddSeconds(schedule.NowNs(),
                              planned_request.plan.options.time_budget_s + kReplanNoticeS));
      planned_request.fleet.replan.notice_s =
          std::min(kMaxReplanNoticeS, SecondsBetween(planned_request.departure_ns, notice_ns));
    }
    Expected<FleetPlanResult> planned = PlanAmongTraffic(*map.map, planned_request, should_stop);
    if (!planned) {
      return ServiceError::FromPlanner(
          planned.error(), PlanRequestField(planned.error().field, request.inline_profile));
    }
    const FleetPlanResult& result = planned.value();
    *timings = result.plan.stats.timings;
    // The whole answer first, so that nothing is committed for an answer that cannot be sent.
    v1::PlanResponse answer;
    if (ServiceStatus written = WritePlan(result.plan, request, max_samples, &answer);
        !written.ok()) {
      return written;
    }
    ToProto(planned_request.departure_ns, answer.mutable_departure_time());
    answer.set_wait_s(result.wait_s);
    answer.set_arrival_s(result.arrival_s);
    for (const FleetHold& hold : result.holds) {
      v1::Hold* out = answer.add_holds();
      out->set_start_s(hold.start_s);
      out->set_duration_s(hold.duration_s);
      ToProto(hold.position_m, out->mutable_position_m());
    }
    if (fleet.reserve) {
      Reservation reservation;
      reservation.map_id = map_id;
      reservation.map_version = map.version;
      reservation.reserved = {fleet.robot_id, result.motion};
      if (fleet.follows_replans) reservation.replan_profile = request.plan.profile;
      std::vector<ReservedMotion> replanned;
      for (const ReplannedRobot& robot : result.replanned) {
        replanned.push_back({traffic.others[robot.other].robot_id, robot.motion});
      }
      Result<std::vector<Reservation>> committed = schedule.CommitReplanning(
          std::move(reservation), replanned, traffic.revision, rule.value(), caller);
      if (!committed.ok()) {
        // Lost a race: another robot committed into this trajectory's way while it was
        // planned. Plan again against the schedule as it is now (unless the others are not
        // avoided, when a new plan would be the same).
        const bool raced =
            committed.error().code == ServiceError::Code(ErrorCode::kReservationConflict);
        if (raced && fleet.avoid_reservations && attempt < kMaxCommitAttempts) continue;
        return std::move(committed).error();
      }
      ToProto(committed.value().front(), answer.mutable_reservation());
      for (std::size_t i = 1; i < committed.value().size(); ++i) {
        ToProto(committed.value()[i], answer.add_replanned());
      }
    }
    *response = std::move(answer);
    return OkStatus();
  }
}

}  // namespace strata::server
