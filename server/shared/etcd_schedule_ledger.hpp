#pragma once
/// The fleet's schedule on etcd, shared by every replica that runs with the same --etcd.
///
/// Keys: <prefix>/schedule/<map id>/<robot id>, each a strata.shared.v1.StoredReservation
/// attached to a lease of its own that ends a second after the reservation does, so that a
/// reservation whose replica died is removed by etcd itself. A write is one Txn that lands
/// only if no key under its map's prefix was modified after the revision this replica has
/// seen (ScheduleLedger's contract); a stale one reads the map back in the same Txn. Each
/// replica follows the prefix with a watch into its ReservationSchedule, which plans read
/// without a call to etcd.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "shared/etcd_client.hpp"
#include "traffic/reservation_schedule.hpp"

namespace strata::server {

class EtcdScheduleLedger final : public ScheduleLedger {
 public:
  /// Attaches itself to `schedule` and follows the shared schedule into it from now on (a
  /// first read, then the watch; while etcd is unreachable, tried again every second).
  /// `on_connection` is told whether etcd is reachable on every change. `client` and
  /// `schedule` outlive the ledger.
  EtcdScheduleLedger(EtcdClient* client, const std::string& prefix, ReservationSchedule* schedule,
                     std::function<void(bool)> on_connection);
  ~EtcdScheduleLedger() override;  // Stops the watch.

  Result<Written> Put(std::span<const Reservation> reservations, std::uint64_t synced_revision,
                      std::int64_t now_ns) override;
  Result<Written> Erase(const std::string& map_id, const std::string& robot_id,
                        std::uint64_t synced_revision) override;
  ServiceStatus EraseMap(const std::string& map_id) override;

  /// Whether the watch is following etcd now.
  bool connected() const { return connected_.load(); }

 private:
  std::string MapPrefix(const std::string& map_id) const;
  // A Txn that makes `changes` when nothing under map_id's prefix changed after
  // synced_revision, and otherwise reads the map back.
  Result<Written> ChangeIfCurrent(const std::string& map_id, std::uint64_t synced_revision,
                                  std::vector<etcdserverpb::RequestOp> changes);
  // Reads the whole schedule into schedule_; returns the revision it read at.
  Result<std::int64_t> ReadAll();
  void OnWatch(const etcdserverpb::WatchResponse& response);

  EtcdClient* const client_;
  const std::string schedule_prefix_;  // "<prefix>/schedule/"
  ReservationSchedule* const schedule_;
  const std::function<void(bool)> on_connection_;
  std::atomic<bool> connected_{false};
  std::unique_ptr<EtcdWatch> watch_;
};

}  // namespace strata::server
