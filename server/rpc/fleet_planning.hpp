#pragma once
/// Plan with a fleet block: one robot planned among the others' reservations on its map, and
/// its trajectory committed as its own reservation when asked, atomically.
#include <functional>
#include <string>

#include "maps/map_registry.hpp"
#include "rpc/planner_service.hpp"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

/// How many times a plan whose commit lost a race (another robot committed into its way while
/// it was planned) is planned again against the new schedule before the conflict is returned.
inline constexpr int kMaxCommitAttempts = 4;

/// Plans `request` (its fleet block set, its time budget capped) on `map` among the live
/// reservations of `map_id` on `schedule` (PlanAmongTraffic), and, with fleet.reserve, commits
/// the trajectory as the robot's reservation. A commit that meets a reservation made while
/// the robot was planned replans against the new schedule, at most kMaxCommitAttempts times
/// in all, each within what is left of the time budget. Writes the response as Plan does,
/// with the departure, the wait and the reservation. Errors as Plan's, blamed on the request's
/// fields, and kReservationConflict naming the robot in the way.
ServiceStatus PlanAmongReservations(const ActiveMap& map, const std::string& map_id,
                                    const ParsedPlanRequest& request, ReservationSchedule& schedule,
                                    const Caller& caller, const std::function<bool()>& should_stop,
                                    int max_samples, v1::PlanResponse* response,
                                    PlanTimings* timings);

}  // namespace strata::server
