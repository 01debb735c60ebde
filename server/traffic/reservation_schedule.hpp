#pragma once
/// The reservations of every map: each robot's committed motion, committed atomically against
/// the others (checked exactly, under one lock per schedule), renewed, released and collected
/// when their leases expire. Kept in this server's memory, and, with a ledger (etcd, --etcd),
/// written there and shared with every replica: the memory is then the replica's cache of
/// the ledger, which plans read without a call. No gRPC here: the traffic service and Plan
/// adapt protobuf to it (rpc/traffic_service.hpp).
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/service_error.hpp"
#include "strata/fleet/fleet_plan.hpp"
#include "strata/fleet/traffic.hpp"
#include "traffic/schedule_ledger.hpp"

namespace strata::server {

/// Set from ServerConfig (server/ops/flags.hpp), which holds the defaults and the flags.
struct ScheduleLimits {
  int max_reservations_per_map = 0;  ///< --max-reservations, >= 1.
  double default_lease_s = 0;        ///< --default-lease-s, in (0, max_lease_s].
  double max_lease_s = 0;            ///< --max-lease-s, > 0.
  /// --max-reservation-horizon-s: how far ahead of now a reservation may start, > 0.
  double max_horizon_s = 0;
  double default_separation_m = 0;  ///< --separation-m, >= 0.
};

/// One robot's committed motion on one map.
struct Reservation {
  std::string map_id;
  std::string map_version;
  ReservedMotion reserved;  ///< reserved.robot_id names the robot; reserved.motion.end_ns is
                            ///< the lease's expiry.
  /// Who made it: a fingerprint of the caller's token (OwnerOf), empty without tokens. Only the
  /// same owner, or an admin, may change it.
  std::string owner;
  /// The map's schedule revision that committed or last changed it (with a ledger, the
  /// ledger's revision of the write).
  std::uint64_t revision = 0;
  /// Set when the robot follows new trajectories the server sends it (FleetOptions.
  /// follows_replans): its profile, which another robot's plan replans it with.
  std::optional<RobotProfile> replan_profile;
  /// The robot whose plan last replanned this one to pass first; empty when its own robot
  /// made this reservation.
  std::string replanned_for;
};

/// Who is asking to change a reservation.
struct Caller {
  std::string owner;   ///< As Reservation::owner.
  bool admin = false;  ///< May change any robot's reservation.
};

/// The nanoseconds since the Unix epoch now (the server's clock).
std::int64_t SystemNowNs();

class ReservationSchedule {
 public:
  /// `now_ns` is the clock (tests pass their own).
  explicit ReservationSchedule(ScheduleLimits limits,
                               std::function<std::int64_t()> now_ns = SystemNowNs);

  const ScheduleLimits& limits() const { return limits_; }

  /// Makes every change go through `ledger` first (set once, before the first call; the ledger
  /// stays until the schedule is no longer called). Revisions are then the ledger's.
  void AttachLedger(ScheduleLedger* ledger);
  std::int64_t NowNs() const { return now_ns_(); }

  /// What a robot plans against on `map_id`: the others' live motions, and the revision.
  struct Traffic {
    std::uint64_t revision = 0;
    std::vector<ReservedMotion> others;
    /// Those of `others` whose robots follow replans, with their profiles.
    std::vector<ReplannableRobot> replannable;
  };
  Traffic OthersOf(const std::string& map_id, const std::string& robot_id);

  /// Checks what a new reservation may be, before any work: a robot id of 1 to 128 printable
  /// characters (blamed as `robot_field`), a start no earlier than a minute ago nor further
  /// ahead than the horizon, a lease in (0, max_lease_s]. kInvalidInput naming the bound.
  ServiceStatus CheckRequest(const std::string& robot_id, std::string_view robot_field,
                             std::int64_t start_ns, double lease_s) const;

  /// kInvalidInput naming --max-lease-s unless `lease_s` is in (0, max_lease_s].
  ServiceStatus CheckLease(double lease_s) const;

  /// Commits `reservation` (its revision is set here, and its motion's separation_m to the
  /// rule's: what the robot asks of the others) as its robot's, replacing the robot's
  /// own earlier one from its departure on (ContinuedBy: the rest of the earlier one, from
  /// now, begins the committed motion), when its motion meets no other live reservation on its
  /// map under `rule` (CheckSeparation, exact); otherwise kReservationConflict naming the
  /// first meeting.
  /// kResourceExhausted when the map holds max_reservations_per_map others already;
  /// kPermissionDenied when the robot's reservation belongs to another owner and `caller` is
  /// no admin. Returns the reservation as committed.
  Result<Reservation> Commit(Reservation reservation, const SeparationRule& rule,
                             const Caller& caller);

  /// Commits `reservation` as Commit does, together with the new motions of the robots its
  /// plan replanned to let it pass first (FleetPlanResult::replanned, robot_id set; none is
  /// Commit), planned on the schedule at `planned_revision`. Each replaces its robot's reservation
  /// from its departure on (ContinuedBy), with replanned_for set to this robot, whoever made it;
  /// each must still follow replans, be unchanged since planned_revision and depart after now, else
  /// kReservationConflict (the plan raced: plan again). Every new motion is checked exactly against
  /// every other reservation, the others of these included, and all are stored at once, or none.
  /// Returns them as committed, `reservation` first.
  Result<std::vector<Reservation>> CommitReplanning(Reservation reservation,
                                                    const std::vector<ReservedMotion>& replanned,
                                                    std::uint64_t planned_revision,
                                                    const SeparationRule& rule,
                                                    const Caller& caller);

  /// Extends robot_id's lease to now + lease_s (never shortening it), when the longer stay
  /// meets no other reservation under `rule`, whose separation the robot then asks.
  /// kReservationNotFound, kPermissionDenied, kReservationConflict (the lease stays as it was).
  Result<Reservation> Renew(const std::string& map_id, const std::string& robot_id, double lease_s,
                            const SeparationRule& rule, const Caller& caller);

  /// Where a moved reservation meets another robot's: that robot, and the first moment.
  struct Meeting {
    std::string robot_id;
    MotionConflict conflict;
  };
  struct Moved {
    Reservation reservation;
    std::vector<Meeting> meetings;  ///< Earliest first.
  };
  /// Moves robot_id's reservation by `delay_s` (its start and its expiry alike): the robot is
  /// late (> 0) or early. Committed even when it then meets others (the robot is where it is);
  /// returns it with its first meeting with each other robot (the larger of the two motions'
  /// separations).
  /// kInvalidInput for a delay that is not finite or longer than the horizon,
  /// kReservationNotFound, kPermissionDenied.
  Result<Moved> Shift(const std::string& map_id, const std::string& robot_id, double delay_s,
                      const Caller& caller);

  /// Removes robot_id's reservation; returns the map's revision after it.
  /// kReservationNotFound, kPermissionDenied.
  Result<std::uint64_t> Release(const std::string& map_id, const std::string& robot_id,
                                const Caller& caller);

  /// The live reservations on `map_id` whose time overlaps [from_ns, to_ns], by robot id,
  /// and the revision.
  struct Listing {
    std::uint64_t revision = 0;
    std::vector<Reservation> reservations;
  };
  Listing List(const std::string& map_id, std::int64_t from_ns = INT64_MIN,
               std::int64_t to_ns = INT64_MAX);

  /// Blocks until `map_id`'s revision differs from `revision`, its map is dropped, the
  /// schedule is closed, or `deadline` passes; returns the revision then (collecting expired
  /// leases first).
  std::uint64_t WaitForChange(const std::string& map_id, std::uint64_t revision,
                              std::chrono::steady_clock::time_point deadline);

  /// Wakes every WaitForChange for good: the server is shutting down.
  void Close();
  bool closed() const;

  /// Forgets every reservation of `map_id` (the map was deleted).
  void DropMap(const std::string& map_id);

  /// From the ledger: every reservation it held at `revision` (a first read, or a read afresh
  /// after its history was compacted). Replaces what this replica knew as of `revision`;
  /// anything it learnt of a later revision stays.
  void ReplaceShared(std::vector<Reservation> reservations, std::uint64_t revision);
  /// From the ledger: robot_id's reservation on map_id became `reservation` (nullopt: removed)
  /// at `revision`. Older news than what this replica holds is ignored.
  void ApplyShared(const std::string& map_id, const std::string& robot_id,
                   std::optional<Reservation> reservation, std::uint64_t revision);

  /// Reservations whose lease has not expired, over every map, and how many expired ones were
  /// collected so far.
  std::size_t size() const;
  std::uint64_t collected() const;
  /// Reservations this replica replanned for other robots' plans (CommitReplanning), so far.
  std::uint64_t replanned() const;

 private:
  using RobotReservations = std::map<std::string, Reservation>;  // By robot id.
  struct MapSchedule {
    std::uint64_t revision = 0;
    RobotReservations by_robot;
  };
  // Moves the schedule's revision (in memory only; with a ledger, the ledger moves it) and
  // wakes the watchers. Call with mutex_ held.
  std::uint64_t NextRevision(MapSchedule& schedule);
  // Makes robot_id's reservation on the map `value` (nullptr: removes it), through the ledger
  // when there is one; returns the revision of the change, with value->revision set to it.
  // nullopt when the ledger had newer changes of the map than this replica: the map is then
  // as the ledger holds it, and the caller must look again.
  Result<std::optional<std::uint64_t>> Store(MapSchedule& schedule, const std::string& map_id,
                                             const std::string& robot_id, Reservation* value);
  // Store for several reservations of `schedule`'s map at once: all of them are written, or
  // none.
  Result<std::optional<std::uint64_t>> StoreAll(MapSchedule& schedule,
                                                std::span<Reservation> values);
  // `reservation` as Commit would store it on `schedule` for `caller`: its owner set, and
  // continuing the robot's earlier reservation (ContinuedBy); kPermissionDenied,
  // kResourceExhausted or kInvalidInput (too many pieces) as Commit says.
  Result<Reservation> Continued(const MapSchedule& schedule, Reservation reservation,
                                const Caller& caller) const;
  // Runs `change(schedule)` on map_id's live schedule under the lock until it is not stale
  // (Store); kSharedStateUnavailable (KeptStale) after kMaxStaleAttempts.
  template <typename T, typename Change>
  Result<T> Retrying(const std::string& map_id, const Change& change);
  // kSharedStateUnavailable: the ledger kept having newer changes than this replica.
  ServiceError KeptStale(const std::string& map_id) const;
  // `schedule` as the ledger held it at `revision`: `reservations`, and whatever this
  // replica learnt of a later revision. Call with mutex_ held.
  void ReplaceMap(MapSchedule& schedule, std::vector<Reservation> reservations,
                  std::uint64_t revision);
  // The map's schedule with expired leases collected (a collection moves the revision).
  // Call with mutex_ held.
  MapSchedule& Live(const std::string& map_id);
  // The reservations of `schedule` but robot_id's, as the planner takes them.
  static std::vector<ReservedMotion> Others(const MapSchedule& schedule,
                                            const std::string& robot_id);
  // robot_id's reservation in `schedule` when `caller` may change it; kReservationNotFound
  // naming `map_id`, or kPermissionDenied.
  static Result<RobotReservations::iterator> Changeable(MapSchedule& schedule,
                                                        const std::string& map_id,
                                                        const std::string& robot_id,
                                                        const Caller& caller);
  // kPermissionDenied unless `caller` may change `existing`.
  static ServiceStatus MayChange(const Reservation& existing, const Caller& caller);

  const ScheduleLimits limits_;
  const std::function<std::int64_t()> now_ns_;
  ScheduleLedger* ledger_ = nullptr;  // Set once before any call; null in memory only.
  mutable std::mutex mutex_;
  std::condition_variable changed_;  // Notified whenever a revision moves or a map is dropped.
  std::map<std::string, MapSchedule> maps_;  // By map id; guarded by mutex_.
  std::uint64_t collected_ = 0;              // Guarded by mutex_.
  std::uint64_t replanned_ = 0;              // Guarded by mutex_.
  bool closed_ = false;                      // Guarded by mutex_.
};

}  // namespace strata::server
