#pragma once
/// Where a ReservationSchedule's changes are made durable and shared with other replicas
/// (etcd: server/shared/etcd_schedule_ledger.hpp). Without a ledger the schedule lives in this
/// process's memory only. No gRPC here.
///
/// The contract: a write lands only when no reservation of its map changed in the ledger
/// after `synced_revision`, the revision up to which the schedule has seen every change of
/// that map; otherwise it is `stale`, and comes back with the map as the ledger holds it, so
/// that the schedule checks again against that and retries. The ledger reports the other
/// replicas' changes through the schedule's ApplyShared and ReplaceShared.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/service_error.hpp"

namespace strata::server {

struct Reservation;  // traffic/reservation_schedule.hpp

class ScheduleLedger {
 public:
  virtual ~ScheduleLedger() = default;

  struct Written {
    /// Another replica changed the map after synced_revision: nothing was written.
    bool stale = false;
    /// The ledger's revision of the write; when stale, the revision it was at.
    std::uint64_t revision = 0;
    /// When stale: every reservation of the map at `revision`.
    std::vector<Reservation> current;
  };
  /// Writes each of `reservations` (at least one, all of one map) as its robot's, kept until
  /// its motion's end_ns (the lease): all of them at once, or none. kSharedStateUnavailable
  /// when the ledger cannot be reached.
  virtual Result<Written> Put(std::span<const Reservation> reservations,
                              std::uint64_t synced_revision, std::int64_t now_ns) = 0;
  /// Removes robot_id's reservation on map_id.
  virtual Result<Written> Erase(const std::string& map_id, const std::string& robot_id,
                                std::uint64_t synced_revision) = 0;
  /// Removes every reservation of map_id (the map was deleted).
  virtual ServiceStatus EraseMap(const std::string& map_id) = 0;
};

}  // namespace strata::server
