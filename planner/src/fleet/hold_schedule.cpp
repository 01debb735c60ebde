#include "hold_schedule.hpp"

#include <algorithm>

namespace strata::fleet_internal {
namespace {

/// An arrival at a stop whose search led nowhere, and the end of the safe interval it held.
struct DeadEnd {
  std::int64_t arrival_ns = 0;
  std::int64_t hold_end_ns = 0;
};

class HoldSearch {
 public:
  HoldSearch(std::span<const Trajectory> legs, bool may_wait_at_start, const Traffic& traffic,
             double max_wait_s, int max_departures, std::optional<ParkedLegs> parked)
      : legs_(legs),
        may_wait_at_start_(may_wait_at_start),
        traffic_(traffic),
        others_(PrepareOthers(traffic.others)),
        max_wait_s_(max_wait_s),
        parked_(parked),
        departures_left_(max_departures),
        dead_ends_(legs.size()),
        waits_s_(legs.size(), 0.0) {}

  std::variant<HoldSchedule, HoldFailure> Run() {
    const int budget = departures_left_;
    if (Visit(0, traffic_.departure_ns, 0.0)) {
      return HoldSchedule{waits_s_, budget - departures_left_};
    }
    failure_.departures_checked = budget - departures_left_;
    return failure_;
  }

 private:
  /// Whether leg `leg` and all after it can be scheduled with the robot at the leg's first
  /// point from `arrival_ns`, having waited `waited_s` before.
  bool Visit(std::size_t leg, std::int64_t arrival_ns, double waited_s) {
    for (const DeadEnd& dead : dead_ends_[leg]) {
      if (dead.arrival_ns <= arrival_ns && arrival_ns < dead.hold_end_ns) return false;
    }
    const bool parked = parked_ && leg >= parked_->first;
    // Leaving the goal to make way: as late as holding there allows.
    const bool latest_first = parked && leg == parked_->first;
    const double remaining_s = latest_first                      ? parked_->max_hold_s
                               : parked                          ? parked_->max_aside_s
                               : leg == 0 && !may_wait_at_start_ ? 0.0
                                                                 : max_wait_s_ - waited_s;
    const std::int64_t hold_end_ns = HoldEnd(leg, arrival_ns, remaining_s);
    const std::vector<double> waits =
        latest_first
            ? WaitLadderBackFrom(std::min(remaining_s, SecondsBetween(arrival_ns, hold_end_ns)))
            : WaitLadder(remaining_s);
    for (const double wait_s : waits) {
      const std::int64_t departure_ns = AddSeconds(arrival_ns, wait_s);
      if (wait_s > 0 && departure_ns >= hold_end_ns) {
        if (latest_first) continue;
        break;
      }
      if (departures_left_ <= 0) return false;
      --departures_left_;
      const std::optional<TrafficConflict> met =
          FirstTrafficConflict(LegMotion(leg, departure_ns), others_, traffic_.rule);
      if (met) {
        NoteFailure(leg, departure_ns, *met);
        continue;
      }
      if (leg + 1 == legs_.size()) {
        waits_s_[leg] = wait_s;
        return true;
      }
      if (leg + 1 > failure_.leg) failure_ = HoldFailure{leg + 1, 0, std::nullopt, 0};
      const std::int64_t next_arrival_ns = AddSeconds(departure_ns, legs_[leg].TotalDuration());
      if (Visit(leg + 1, next_arrival_ns, waited_s + wait_s)) {
        waits_s_[leg] = wait_s;
        return true;
      }
    }
    dead_ends_[leg].push_back({arrival_ns, hold_end_ns});
    return false;
  }

  /// Keeps, for the last leg reached, the departure that got furthest along it before it met
  /// another robot: a stop before that meeting is the likeliest to help.
  void NoteFailure(std::size_t leg, std::int64_t departure_ns, const TrafficConflict& met) {
    const auto progress_ns = [](std::int64_t departure, const TrafficConflict& conflict) {
      return conflict.conflict.time_ns - departure;
    };
    if (leg > failure_.leg ||
        (leg == failure_.leg &&
         (!failure_.conflict || progress_ns(departure_ns, met) >
                                    progress_ns(failure_.departure_ns, *failure_.conflict)))) {
      failure_ = HoldFailure{leg, departure_ns, met, 0};
    }
  }

  /// The first moment at which holding at leg `leg`'s first point from `arrival_ns` for up to
  /// `remaining_s` would meet another robot, or the end of that hold when it meets none.
  std::int64_t HoldEnd(std::size_t leg, std::int64_t arrival_ns, double remaining_s) const {
    if (remaining_s <= 0) return arrival_ns;
    FleetMotion hold;
    hold.start_ns = arrival_ns;
    hold.trajectory.dimension = legs_[leg].dimension;
    hold.trajectory.pieces = {RestAtStart(legs_[leg], remaining_s)};
    hold.body = traffic_.body;
    hold.end_ns = hold.ArrivalNs();
    const std::optional<TrafficConflict> met = FirstTrafficConflict(hold, others_, traffic_.rule);
    return met ? met->conflict.time_ns : hold.end_ns + 1;
  }

  /// Leg `leg` leaving at `departure_ns`; the last one then stays parked as the robot will.
  FleetMotion LegMotion(std::size_t leg, std::int64_t departure_ns) const {
    FleetMotion motion;
    motion.start_ns = departure_ns;
    motion.trajectory = legs_[leg];
    motion.body = traffic_.body;
    motion.end_ns = motion.ArrivalNs();
    if (leg + 1 == legs_.size()) motion.end_ns = std::max(motion.end_ns, traffic_.parked_until_ns);
    return motion;
  }

  std::span<const Trajectory> legs_;
  bool may_wait_at_start_;
  const Traffic& traffic_;
  // The others, prepared once for the departures checked against them all.
  std::vector<PreparedMotion> others_;
  double max_wait_s_;
  std::optional<ParkedLegs> parked_;
  int departures_left_;
  std::vector<std::vector<DeadEnd>> dead_ends_;  // Per leg, at its first point.
  std::vector<double> waits_s_;
  HoldFailure failure_;
};

}  // namespace

std::vector<double> WaitLadder(double max_wait_s) {
  std::vector<double> waits = {0.0};
  for (double w = 0.5; w < max_wait_s; w = std::max(w + 0.5, w * 1.25)) waits.push_back(w);
  if (max_wait_s > 0) waits.push_back(max_wait_s);
  return waits;
}

std::vector<double> WaitLadderBackFrom(double hold_s) {
  std::vector<double> waits;
  for (const double step_s : WaitLadder(hold_s)) {
    if (step_s > 0 && step_s < hold_s) waits.push_back(hold_s - step_s);
  }
  waits.push_back(0.0);
  return waits;
}

TrajectoryPiece RestAtStart(const Trajectory& trajectory, double duration_s) {
  return RestAt(trajectory.EvaluatePiece(0, 0, 0), duration_s);
}

std::variant<HoldSchedule, HoldFailure> ScheduleHolds(std::span<const Trajectory> legs,
                                                      bool may_wait_at_start,
                                                      const Traffic& traffic, double max_wait_s,
                                                      int max_departures,
                                                      std::optional<ParkedLegs> parked) {
  return HoldSearch(legs, may_wait_at_start, traffic, max_wait_s, max_departures, parked).Run();
}

}  // namespace strata::fleet_internal
