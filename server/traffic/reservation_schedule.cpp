#include "traffic/reservation_schedule.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <random>
#include <span>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include "common/log.hpp"

namespace strata::server {
namespace {

constexpr std::size_t kMaxRobotIdLength = 128;
// How far in the past a reservation may start [s]: a robot that asked a moment ago, or whose
// clock is slightly behind the server's, is not refused.
constexpr double kMaxStartInPastS = 60;
// How often a change is tried again when the ledger keeps having newer changes of its map
// than this replica (each try reads the map afresh, after a random back-off).
constexpr int kMaxStaleAttempts = 10;

bool Printable(const std::string& text) {
  return std::all_of(text.begin(), text.end(), [](char c) { return c > ' ' && c != 0x7f; });
}

}  // namespace

std::int64_t SystemNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

ReservationSchedule::ReservationSchedule(ScheduleLimits limits,
                                         std::function<std::int64_t()> now_ns)
    : limits_(limits), now_ns_(std::move(now_ns)) {}

ServiceStatus ReservationSchedule::CheckRequest(const std::string& robot_id,
                                                std::string_view robot_field, std::int64_t start_ns,
                                                double lease_s) const {
  if (robot_id.empty() || robot_id.size() > kMaxRobotIdLength || !Printable(robot_id)) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("{} must be 1 to {} printable characters without spaces; got "
                                 "{} characters",
                                 robot_field, kMaxRobotIdLength, robot_id.size()))
        .Blame(std::string(robot_field));
  }
  const double ahead_s = SecondsBetween(now_ns_(), start_ns);
  if (ahead_s > limits_.max_horizon_s || ahead_s < -kMaxStartInPastS) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("the trajectory would start {:.1f} s from now: this server "
                                 "takes starts from {:.0f} s ago to {:.0f} s ahead "
                                 "(--max-reservation-horizon-s)",
                                 ahead_s, kMaxStartInPastS, limits_.max_horizon_s));
  }
  return CheckLease(lease_s);
}

ServiceStatus ReservationSchedule::CheckLease(double lease_s) const {
  if (lease_s > 0 && lease_s <= limits_.max_lease_s) return OkStatus();
  return MakeError(ErrorCode::kInvalidInput,
                   fmt::format("lease_s = {:g} is out of range: must be > 0 and at most {:g} "
                               "(--max-lease-s)",
                               lease_s, limits_.max_lease_s));
}

void ReservationSchedule::AttachLedger(ScheduleLedger* ledger) { ledger_ = ledger; }

std::uint64_t ReservationSchedule::NextRevision(MapSchedule& schedule) {
  changed_.notify_all();
  return ledger_ != nullptr ? schedule.revision : ++schedule.revision;
}

Result<std::optional<std::uint64_t>> ReservationSchedule::Store(MapSchedule& schedule,
                                                                const std::string& map_id,
                                                                const std::string& robot_id,
                                                                Reservation* value) {
  if (value != nullptr) return StoreAll(schedule, std::span<Reservation>(value, 1));
  if (ledger_ == nullptr) {
    const std::uint64_t revision = NextRevision(schedule);
    schedule.by_robot.erase(robot_id);
    return std::optional(revision);
  }
  // The call is made under the lock: this replica's changes stay in the order the ledger
  // takes them (a round trip, about a millisecond on a local network).
  Result<ScheduleLedger::Written> written = ledger_->Erase(map_id, robot_id, schedule.revision);
  if (!written.ok()) return std::move(written).error();
  const std::uint64_t revision = written.value().revision;
  if (written.value().stale) {
    // Another replica changed the map after what this one has seen: take the map as the
    // ledger holds it now, and let the caller look again.
    ReplaceMap(schedule, std::move(written.value().current), revision);
    return std::optional<std::uint64_t>();
  }
  schedule.by_robot.erase(robot_id);
  schedule.revision = std::max(schedule.revision, revision);
  changed_.notify_all();
  return std::optional(revision);
}

Result<std::optional<std::uint64_t>> ReservationSchedule::StoreAll(MapSchedule& schedule,
                                                                   std::span<Reservation> values) {
  std::uint64_t revision = 0;
  if (ledger_ == nullptr) {
    revision = NextRevision(schedule);
  } else {
    // Under the lock, as Store.
    Result<ScheduleLedger::Written> written = ledger_->Put(values, schedule.revision, now_ns_());
    if (!written.ok()) return std::move(written).error();
    revision = written.value().revision;
    if (written.value().stale) {
      ReplaceMap(schedule, std::move(written.value().current), revision);
      return std::optional<std::uint64_t>();
    }
    schedule.revision = std::max(schedule.revision, revision);
    changed_.notify_all();
  }
  for (Reservation& value : values) {
    value.revision = revision;
    schedule.by_robot[value.reserved.robot_id] = value;
  }
  return std::optional(revision);
}

ServiceError ReservationSchedule::KeptStale(const std::string& map_id) const {
  return MakeError(ServiceErrorCode::kSharedStateUnavailable,
                   fmt::format("map {}'s reservations kept changing on other replicas faster "
                               "than this replica's watch of the shared schedule caught up ({} "
                               "tries): retry",
                               map_id, kMaxStaleAttempts));
}

ReservationSchedule::MapSchedule& ReservationSchedule::Live(const std::string& map_id) {
  MapSchedule& schedule = maps_[map_id];
  const std::int64_t now = now_ns_();
  const std::size_t expired = std::erase_if(schedule.by_robot, [now](const auto& entry) {
    return entry.second.reserved.motion.end_ns < now;
  });
  if (expired > 0) {
    collected_ += expired;
    NextRevision(schedule);
  }
  return schedule;
}

std::vector<ReservedMotion> ReservationSchedule::Others(const MapSchedule& schedule,
                                                        const std::string& robot_id) {
  std::vector<ReservedMotion> others;
  others.reserve(schedule.by_robot.size());
  for (const auto& [robot, reservation] : schedule.by_robot) {
    if (robot != robot_id) others.push_back(reservation.reserved);
  }
  return others;
}

ServiceStatus ReservationSchedule::MayChange(const Reservation& existing, const Caller& caller) {
  if (caller.admin || existing.owner == caller.owner) return OkStatus();
  return MakeError(ServiceErrorCode::kPermissionDenied,
                   fmt::format("robot {}'s reservation was made with another token: only that "
                               "token or an admin one may change it",
                               existing.reserved.robot_id));
}

Result<ReservationSchedule::RobotReservations::iterator> ReservationSchedule::Changeable(
    MapSchedule& schedule, const std::string& map_id, const std::string& robot_id,
    const Caller& caller) {
  const auto found = schedule.by_robot.find(robot_id);
  if (found == schedule.by_robot.end()) {
    return MakeError(ServiceErrorCode::kReservationNotFound,
                     fmt::format("robot {} holds no reservation on map {} (never made, released, "
                                 "or its lease expired): plan or reserve again",
                                 robot_id, map_id));
  }
  if (ServiceStatus may = MayChange(found->second, caller); !may.ok()) return may.error();
  return found;
}

ReservationSchedule::Traffic ReservationSchedule::OthersOf(const std::string& map_id,
                                                           const std::string& robot_id) {
  std::lock_guard lock(mutex_);
  const MapSchedule& schedule = Live(map_id);
  Traffic traffic{schedule.revision, {}, {}};
  traffic.others.reserve(schedule.by_robot.size());
  for (const auto& [robot, reservation] : schedule.by_robot) {
    if (robot == robot_id) continue;
    if (reservation.replan_profile) {
      traffic.replannable.push_back({traffic.others.size(), *reservation.replan_profile});
    }
    traffic.others.push_back(reservation.reserved);
  }
  return traffic;
}

template <typename T, typename Change>
Result<T> ReservationSchedule::Retrying(const std::string& map_id, const Change& change) {
  thread_local std::minstd_rand jitter(std::random_device{}());
  for (int attempt = 0; attempt < kMaxStaleAttempts; ++attempt) {
    {
      std::lock_guard lock(mutex_);
      Result<std::optional<T>> changed = change(Live(map_id));
      if (!changed.ok()) return std::move(changed).error();
      if (changed.value()) return *std::move(changed).value();
    }
    // Another replica wrote the map first. Replicas writing one map as fast as they can would
    // otherwise keep colliding in step: back off a random while, longer each time.
    const int ceiling_us = 500 << std::min(attempt, 5);
    std::this_thread::sleep_for(
        std::chrono::microseconds(std::uniform_int_distribution<int>(0, ceiling_us)(jitter)));
  }
  return KeptStale(map_id);
}

Result<Reservation> ReservationSchedule::Continued(const MapSchedule& schedule,
                                                   Reservation reservation,
                                                   const Caller& caller) const {
  const std::string& robot_id = reservation.reserved.robot_id;
  reservation.owner = caller.owner;
  const auto existing = schedule.by_robot.find(robot_id);
  if (existing == schedule.by_robot.end()) {
    if (static_cast<int>(schedule.by_robot.size()) >= limits_.max_reservations_per_map) {
      return MakeError(ErrorCode::kResourceExhausted,
                       fmt::format("map {} holds {} reservations, the most this server "
                                   "keeps per map (--max-reservations): release some first",
                                   reservation.map_id, schedule.by_robot.size()));
    }
    return reservation;
  }
  if (ServiceStatus may = MayChange(existing->second, caller); !may.ok()) return may.error();
  // Until its new departure the robot drives its earlier plan, which the others were planned
  // around; only what is new needs checking.
  reservation.reserved.motion =
      ContinuedBy(existing->second.reserved.motion, reservation.reserved.motion, now_ns_());
  const std::size_t pieces = reservation.reserved.motion.trajectory.pieces.size();
  if (pieces > kMaxTrajectoryPieces) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("robot {} keeps to its reservation until the new "
                                 "trajectory departs, and the two have {} pieces, more "
                                 "than the {} a reservation may hold: depart sooner, or "
                                 "release the reservation first",
                                 robot_id, pieces, kMaxTrajectoryPieces))
        .Blame("trajectory");
  }
  return reservation;
}

Result<Reservation> ReservationSchedule::Commit(Reservation reservation, const SeparationRule& rule,
                                                const Caller& caller) {
  Result<std::vector<Reservation>> committed =
      CommitReplanning(std::move(reservation), {}, 0, rule, caller);
  if (!committed.ok()) return std::move(committed).error();
  return std::move(committed.value().front());
}

Result<std::vector<Reservation>> ReservationSchedule::CommitReplanning(
    Reservation reservation, const std::vector<ReservedMotion>& replanned,
    std::uint64_t planned_revision, const SeparationRule& rule, const Caller& caller) {
  const std::string& robot_id = reservation.reserved.robot_id;
  // This robot asks the rule's separation; the robots replanned keep theirs. Each pair is then
  // checked with the larger of its two motions' (PairSeparationM), as they were planned.
  reservation.reserved.motion.separation_m = rule.separation_m;
  SeparationRule pairs_rule = rule;
  pairs_rule.separation_m = 0;
  return Retrying<std::vector<Reservation>>(
      reservation.map_id,
      [&](MapSchedule& schedule) -> Result<std::optional<std::vector<Reservation>>> {
        // The new motions as planned, and the reservations to store, this robot's first.
        std::vector<ReservedMotion> planned = {reservation.reserved};
        std::vector<Reservation> committed;
        Result<Reservation> own = Continued(schedule, reservation, caller);
        if (!own.ok()) return std::move(own).error();
        committed.push_back(std::move(own).value());
        for (const ReservedMotion& next : replanned) {
          const auto existing = schedule.by_robot.find(next.robot_id);
          if (existing == schedule.by_robot.end() || !existing->second.replan_profile ||
              existing->second.revision > planned_revision) {
            return MakeError(ErrorCode::kReservationConflict,
                             fmt::format("robot {}'s reservation changed while robot {} was "
                                         "planned to pass first: plan again",
                                         next.robot_id, robot_id));
          }
          if (next.motion.start_ns <= now_ns_()) {
            return MakeError(ErrorCode::kReservationConflict,
                             fmt::format("robot {}'s new trajectory would have departed already "
                                         "when robot {} committed: plan again",
                                         next.robot_id, robot_id));
          }
          Reservation changed = existing->second;
          changed.map_version = reservation.map_version;
          changed.replanned_for = robot_id;
          changed.reserved.motion =
              ContinuedBy(existing->second.reserved.motion, next.motion, now_ns_());
          planned.push_back(next);
          committed.push_back(std::move(changed));
        }
        // Each new motion against the reservations that stay and what the others become.
        std::vector<ReservedMotion> staying;
        for (const auto& entry : schedule.by_robot) {
          const bool changes =
              std::any_of(committed.begin(), committed.end(),
                          [&](const Reservation& c) { return c.reserved.robot_id == entry.first; });
          if (!changes) staying.push_back(entry.second.reserved);
        }
        for (std::size_t i = 0; i < planned.size(); ++i) {
          std::vector<ReservedMotion> around = staying;
          for (std::size_t j = 0; j < committed.size(); ++j) {
            if (j != i) around.push_back(committed[j].reserved);
          }
          if (Status clear = CheckSeparation(planned[i].motion, around, pairs_rule); !clear) {
            return ServiceError::FromPlanner(clear.error());
          }
        }
        Result<std::optional<std::uint64_t>> stored = StoreAll(schedule, committed);
        if (!stored.ok()) return std::move(stored).error();
        if (!stored.value()) return std::optional<std::vector<Reservation>>();
        replanned_ += replanned.size();
        return std::optional(std::move(committed));
      });
}

Result<Reservation> ReservationSchedule::Renew(const std::string& map_id,
                                               const std::string& robot_id, double lease_s,
                                               const SeparationRule& rule, const Caller& caller) {
  return Retrying<Reservation>(
      map_id, [&](MapSchedule& schedule) -> Result<std::optional<Reservation>> {
        Result<RobotReservations::iterator> changeable =
            Changeable(schedule, map_id, robot_id, caller);
        if (!changeable.ok()) return std::move(changeable).error();
        Reservation renewed = changeable.value()->second;
        FleetMotion& motion = renewed.reserved.motion;
        motion.end_ns = std::max(motion.end_ns, AddSeconds(now_ns_(), lease_s));
        motion.separation_m = rule.separation_m;
        const std::vector<ReservedMotion> others = Others(schedule, robot_id);
        if (Status clear = CheckSeparation(motion, others, rule); !clear) {
          return ServiceError::FromPlanner(clear.error());
        }
        Result<std::optional<std::uint64_t>> stored = Store(schedule, map_id, robot_id, &renewed);
        if (!stored.ok()) return std::move(stored).error();
        if (!stored.value()) return std::optional<Reservation>();
        return std::optional(std::move(renewed));
      });
}

Result<ReservationSchedule::Moved> ReservationSchedule::Shift(const std::string& map_id,
                                                              const std::string& robot_id,
                                                              double delay_s,
                                                              const Caller& caller) {
  if (!(std::isfinite(delay_s) && std::abs(delay_s) <= limits_.max_horizon_s)) {
    return MakeError(ErrorCode::kInvalidInput,
                     fmt::format("delay_s = {:g} is out of range: must be finite and at most {:g} "
                                 "s either way (--max-reservation-horizon-s)",
                                 delay_s, limits_.max_horizon_s))
        .Blame("delay_s");
  }
  return Retrying<Moved>(map_id, [&](MapSchedule& schedule) -> Result<std::optional<Moved>> {
    Result<RobotReservations::iterator> changeable = Changeable(schedule, map_id, robot_id, caller);
    if (!changeable.ok()) return std::move(changeable).error();
    Moved moved{changeable.value()->second, {}};
    FleetMotion& motion = moved.reservation.reserved.motion;
    motion.start_ns = AddSeconds(motion.start_ns, delay_s);
    motion.end_ns = AddSeconds(motion.end_ns, delay_s);
    Result<std::optional<std::uint64_t>> stored =
        Store(schedule, map_id, robot_id, &moved.reservation);
    if (!stored.ok()) return std::move(stored).error();
    if (!stored.value()) return std::optional<Moved>();
    const PreparedMotion moved_motion(motion);  // Checked against every other robot.
    SeparationRule rule;
    rule.separation_m = 0;  // The pair's separation is the larger of the two motions'.
    for (const auto& [robot, other] : schedule.by_robot) {
      if (robot == robot_id) continue;
      if (std::optional<MotionConflict> meeting =
              FirstConflict(moved_motion, PreparedMotion(other.reserved.motion), rule)) {
        moved.meetings.push_back({robot, *meeting});
      }
    }
    std::sort(moved.meetings.begin(), moved.meetings.end(), [](const Meeting& a, const Meeting& b) {
      return a.conflict.time_ns < b.conflict.time_ns;
    });
    return std::optional(std::move(moved));
  });
}

Result<std::uint64_t> ReservationSchedule::Release(const std::string& map_id,
                                                   const std::string& robot_id,
                                                   const Caller& caller) {
  return Retrying<std::uint64_t>(
      map_id, [&](MapSchedule& schedule) -> Result<std::optional<std::uint64_t>> {
        Result<RobotReservations::iterator> changeable =
            Changeable(schedule, map_id, robot_id, caller);
        if (!changeable.ok()) return std::move(changeable).error();
        return Store(schedule, map_id, robot_id, nullptr);
      });
}

ReservationSchedule::Listing ReservationSchedule::List(const std::string& map_id,
                                                       std::int64_t from_ns, std::int64_t to_ns) {
  std::lock_guard lock(mutex_);
  const MapSchedule& schedule = Live(map_id);
  Listing listing{schedule.revision, {}};
  for (const auto& [robot, reservation] : schedule.by_robot) {
    const FleetMotion& motion = reservation.reserved.motion;
    if (motion.end_ns >= from_ns && motion.start_ns <= to_ns) {
      listing.reservations.push_back(reservation);
    }
  }
  return listing;
}

std::uint64_t ReservationSchedule::WaitForChange(const std::string& map_id, std::uint64_t revision,
                                                 std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  changed_.wait_until(lock, deadline, [&] {
    const auto found = maps_.find(map_id);
    return closed_ || found == maps_.end() || found->second.revision != revision;
  });
  return Live(map_id).revision;
}

void ReservationSchedule::Close() {
  std::lock_guard lock(mutex_);
  closed_ = true;
  changed_.notify_all();
}

bool ReservationSchedule::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

void ReservationSchedule::DropMap(const std::string& map_id) {
  if (ledger_ != nullptr) {
    // The other replicas learn of it through the ledger. A failure leaves the reservations
    // to their leases, which end them anyway.
    if (ServiceStatus erased = ledger_->EraseMap(map_id); !erased.ok()) {
      LogWarning("shared_reservations_kept")
          .Add("map", map_id)
          .Add("message", erased.error().message + "; they end with their leases");
    }
  }
  std::lock_guard lock(mutex_);
  maps_.erase(map_id);
  changed_.notify_all();
}

void ReservationSchedule::ReplaceMap(MapSchedule& schedule, std::vector<Reservation> reservations,
                                     std::uint64_t revision) {
  std::erase_if(schedule.by_robot,
                [&](const auto& entry) { return entry.second.revision <= revision; });
  for (Reservation& reservation : reservations) {
    Reservation& held = schedule.by_robot[reservation.reserved.robot_id];
    if (held.revision <= reservation.revision) held = std::move(reservation);
  }
  schedule.revision = std::max(schedule.revision, revision);
  changed_.notify_all();
}

void ReservationSchedule::ReplaceShared(std::vector<Reservation> reservations,
                                        std::uint64_t revision) {
  std::map<std::string, std::vector<Reservation>> by_map;
  for (Reservation& reservation : reservations) {
    by_map[reservation.map_id].push_back(std::move(reservation));
  }
  std::lock_guard lock(mutex_);
  for (auto& [id, schedule] : maps_) {
    const auto read = by_map.find(id);
    ReplaceMap(schedule,
               read == by_map.end() ? std::vector<Reservation>() : std::move(read->second),
               revision);
    if (read != by_map.end()) by_map.erase(read);
  }
  for (auto& [id, read] : by_map) ReplaceMap(maps_[id], std::move(read), revision);
}

void ReservationSchedule::ApplyShared(const std::string& map_id, const std::string& robot_id,
                                      std::optional<Reservation> reservation,
                                      std::uint64_t revision) {
  std::lock_guard lock(mutex_);
  MapSchedule& schedule = maps_[map_id];
  const auto held = schedule.by_robot.find(robot_id);
  const bool newer = held == schedule.by_robot.end() || held->second.revision < revision;
  if (newer && reservation) {
    reservation->revision = revision;
    schedule.by_robot[robot_id] = std::move(*reservation);
  } else if (newer && held != schedule.by_robot.end()) {
    schedule.by_robot.erase(held);
  }
  schedule.revision = std::max(schedule.revision, revision);
  changed_.notify_all();
}

std::size_t ReservationSchedule::size() const {
  std::lock_guard lock(mutex_);
  const std::int64_t now = now_ns_();
  std::size_t total = 0;
  for (const auto& [id, schedule] : maps_) {
    total += std::count_if(
        schedule.by_robot.begin(), schedule.by_robot.end(),
        [now](const auto& entry) { return entry.second.reserved.motion.end_ns >= now; });
  }
  return total;
}

std::uint64_t ReservationSchedule::collected() const {
  std::lock_guard lock(mutex_);
  return collected_;
}

std::uint64_t ReservationSchedule::replanned() const {
  std::lock_guard lock(mutex_);
  return replanned_;
}

}  // namespace strata::server
