#include "shared/etcd_schedule_ledger.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "common/log.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "strata/shared/v1/shared_state.pb.h"

namespace strata::server {
namespace {

// A reservation's lease outlives its end by this much [s]: etcd counts whole seconds, and the
// replicas collect an ended reservation by their own clocks first.
constexpr std::int64_t kLeaseMarginS = 1;

std::string Encode(const Reservation& reservation) {
  shared::v1::StoredReservation stored;
  ToProto(reservation, stored.mutable_reservation());
  stored.set_owner(reservation.owner);
  if (reservation.replan_profile) ToProto(*reservation.replan_profile, stored.mutable_profile());
  return stored.SerializeAsString();
}

Result<Reservation> Decode(const mvccpb::KeyValue& kv) {
  shared::v1::StoredReservation stored;
  if (!stored.ParseFromString(kv.value())) {
    return MakeError(ErrorCode::kInvalidInput, "not a StoredReservation");
  }
  Result<Reservation> reservation = FromProto(stored.reservation());
  if (!reservation.ok()) return std::move(reservation).error();
  reservation.value().owner = stored.owner();
  reservation.value().revision = static_cast<std::uint64_t>(kv.mod_revision());
  if (stored.reservation().follows_replans()) {
    Result<RobotProfile> profile = ProfileFromProto(stored.profile());
    if (!profile.ok()) return std::move(profile).error();
    reservation.value().replan_profile = std::move(profile).value();
  }
  return reservation;
}

}  // namespace

EtcdScheduleLedger::EtcdScheduleLedger(EtcdClient* client, const std::string& prefix,
                                       ReservationSchedule* schedule,
                                       std::function<void(bool)> on_connection)
    : client_(client),
      schedule_prefix_(prefix + "/schedule/"),
      schedule_(schedule),
      on_connection_(std::move(on_connection)) {
  schedule_->AttachLedger(this);
  EtcdWatch::Handlers handlers;
  handlers.on_response = [this](const etcdserverpb::WatchResponse& r) { OnWatch(r); };
  handlers.resync = [this] { return ReadAll(); };
  handlers.on_connection = [this](bool connected) {
    connected_.store(connected);
    if (connected) {
      LogInfo("etcd_connected").Add("endpoints", client_->endpoints_text());
    } else {
      LogWarning("etcd_unreachable")
          .Add("endpoints", client_->endpoints_text())
          .Add("message",
               "reservations cannot be committed or changed until etcd answers; plans on the "
               "last known schedule continue");
    }
    if (on_connection_) on_connection_(connected);
  };
  watch_ = std::make_unique<EtcdWatch>(client_, schedule_prefix_, 0, std::move(handlers));
}

EtcdScheduleLedger::~EtcdScheduleLedger() { watch_.reset(); }

std::string EtcdScheduleLedger::MapPrefix(const std::string& map_id) const {
  return schedule_prefix_ + map_id + "/";
}

Result<ScheduleLedger::Written> EtcdScheduleLedger::ChangeIfCurrent(
    const std::string& map_id, std::uint64_t synced_revision,
    std::vector<etcdserverpb::RequestOp> changes) {
  const std::string map_prefix = MapPrefix(map_id);
  etcdserverpb::TxnRequest txn;
  // Every key of the map last modified at or before synced_revision (true for none).
  etcdserverpb::Compare* unchanged = txn.add_compare();
  unchanged->set_result(etcdserverpb::Compare::LESS);
  unchanged->set_target(etcdserverpb::Compare::MOD);
  unchanged->set_key(map_prefix);
  unchanged->set_range_end(PrefixRangeEnd(map_prefix));
  unchanged->set_mod_revision(static_cast<std::int64_t>(synced_revision) + 1);
  for (etcdserverpb::RequestOp& change : changes) *txn.add_success() = std::move(change);
  etcdserverpb::RangeRequest* read = txn.add_failure()->mutable_request_range();
  read->set_key(map_prefix);
  read->set_range_end(PrefixRangeEnd(map_prefix));
  Result<etcdserverpb::TxnResponse> response = client_->Txn(txn);
  if (!response.ok()) return std::move(response).error();
  Written written;
  written.revision = static_cast<std::uint64_t>(response.value().header().revision());
  if (response.value().succeeded()) return written;
  written.stale = true;
  for (const etcdserverpb::ResponseOp& op : response.value().responses()) {
    for (const mvccpb::KeyValue& kv : op.response_range().kvs()) {
      Result<Reservation> reservation = Decode(kv);
      if (reservation.ok()) written.current.push_back(std::move(reservation).value());
    }
  }
  return written;
}

Result<ScheduleLedger::Written> EtcdScheduleLedger::Put(std::span<const Reservation> reservations,
                                                        std::uint64_t synced_revision,
                                                        std::int64_t now_ns) {
  std::vector<etcdserverpb::RequestOp> changes;
  for (const Reservation& reservation : reservations) {
    const double left_s = SecondsBetween(now_ns, reservation.reserved.motion.end_ns);
    const auto ttl_s = static_cast<std::int64_t>(std::ceil(std::max(left_s, 1.0))) + kLeaseMarginS;
    Result<std::int64_t> lease = client_->GrantLease(ttl_s);
    if (!lease.ok()) return std::move(lease).error();
    etcdserverpb::PutRequest* put = changes.emplace_back().mutable_request_put();
    put->set_key(MapPrefix(reservation.map_id) + reservation.reserved.robot_id);
    put->set_value(Encode(reservation));
    put->set_lease(lease.value());
  }
  // A stale write leaves its leases unused: they end by themselves after their ttl.
  return ChangeIfCurrent(reservations.front().map_id, synced_revision, std::move(changes));
}

Result<ScheduleLedger::Written> EtcdScheduleLedger::Erase(const std::string& map_id,
                                                          const std::string& robot_id,
                                                          std::uint64_t synced_revision) {
  std::vector<etcdserverpb::RequestOp> changes(1);
  changes.front().mutable_request_delete_range()->set_key(MapPrefix(map_id) + robot_id);
  return ChangeIfCurrent(map_id, synced_revision, std::move(changes));
}

ServiceStatus EtcdScheduleLedger::EraseMap(const std::string& map_id) {
  etcdserverpb::TxnRequest txn;
  etcdserverpb::DeleteRangeRequest* erase = txn.add_success()->mutable_request_delete_range();
  erase->set_key(MapPrefix(map_id));
  erase->set_range_end(PrefixRangeEnd(MapPrefix(map_id)));
  Result<etcdserverpb::TxnResponse> response = client_->Txn(txn);
  if (!response.ok()) return std::move(response).error();
  return OkStatus();
}

Result<std::int64_t> EtcdScheduleLedger::ReadAll() {
  Result<etcdserverpb::RangeResponse> read = client_->RangePrefix(schedule_prefix_);
  if (!read.ok()) return std::move(read).error();
  std::vector<Reservation> reservations;
  for (const mvccpb::KeyValue& kv : read.value().kvs()) {
    Result<Reservation> reservation = Decode(kv);
    if (!reservation.ok()) {
      LogWarning("shared_reservation_unreadable")
          .Add("key", kv.key())
          .Add("message", reservation.error().message);
      continue;
    }
    reservations.push_back(std::move(reservation).value());
  }
  const std::int64_t revision = read.value().header().revision();
  schedule_->ReplaceShared(std::move(reservations), static_cast<std::uint64_t>(revision));
  return revision;
}

void EtcdScheduleLedger::OnWatch(const etcdserverpb::WatchResponse& response) {
  for (const mvccpb::Event& event : response.events()) {
    const std::string& key = event.kv().key();
    if (!key.starts_with(schedule_prefix_)) continue;
    const std::size_t slash = key.find('/', schedule_prefix_.size());
    if (slash == std::string::npos) continue;
    const std::string map_id = key.substr(schedule_prefix_.size(), slash - schedule_prefix_.size());
    const std::string robot_id = key.substr(slash + 1);
    const auto revision = static_cast<std::uint64_t>(event.kv().mod_revision());
    if (event.type() == mvccpb::Event::DELETE) {
      schedule_->ApplyShared(map_id, robot_id, std::nullopt, revision);
      continue;
    }
    Result<Reservation> reservation = Decode(event.kv());
    if (!reservation.ok()) {
      LogWarning("shared_reservation_unreadable")
          .Add("key", key)
          .Add("message", reservation.error().message);
      continue;
    }
    schedule_->ApplyShared(map_id, robot_id, std::move(reservation).value(), revision);
  }
}

}  // namespace strata::server
