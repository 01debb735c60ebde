#include "shared/etcd_map_heads.hpp"

#include <sstream>
#include <utility>

namespace strata::server {
namespace {

std::string Join(const std::vector<std::string>& versions) {
  std::string text;
  for (const std::string& version : versions) text += version + "\n";
  return text;
}

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> versions;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) versions.push_back(line);
  }
  return versions;
}

ServiceError NotReadYet(const EtcdClient& client) {
  return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                   "map store: the maps' heads on etcd at " + client.endpoints_text() +
                       " have not been read yet (etcd unreachable since this server started): "
                       "retry when it answers");
}

}  // namespace

EtcdMapHeads::EtcdMapHeads(EtcdClient* client, const std::string& prefix)
    : client_(client), prefix_(prefix + "/heads/") {
  EtcdWatch::Handlers handlers;
  handlers.resync = [this] { return ReadAll(); };
  handlers.on_response = [this](const etcdserverpb::WatchResponse& response) {
    for (const mvccpb::Event& event : response.events()) {
      const std::string id = event.kv().key().substr(prefix_.size());
      Apply(id, event.type() == mvccpb::Event::DELETE ? Head() : Head(Split(event.kv().value())),
            event.kv().mod_revision());
    }
  };
  watch_ = std::make_unique<EtcdWatch>(client_, prefix_, 0, std::move(handlers));
}

EtcdMapHeads::~EtcdMapHeads() { watch_.reset(); }

void EtcdMapHeads::Apply(const std::string& id, const Head& head, std::int64_t revision) {
  std::lock_guard lock(mutex_);
  const auto held = heads_.find(id);
  const auto gone = deleted_.find(id);
  const std::int64_t newest = std::max(held == heads_.end() ? 0 : held->second.revision,
                                       gone == deleted_.end() ? 0 : gone->second);
  if (revision <= newest) return;
  if (head) {
    heads_[id] = {*head, revision};
    if (gone != deleted_.end()) deleted_.erase(gone);
  } else {
    if (held != heads_.end()) heads_.erase(held);
    deleted_[id] = revision;
  }
}

Result<std::int64_t> EtcdMapHeads::ReadAll() {
  Result<etcdserverpb::RangeResponse> read = client_->RangePrefix(prefix_);
  if (!read.ok()) return std::move(read).error();
  const std::int64_t revision = read.value().header().revision();
  std::map<std::string, Held> fresh;
  for (const mvccpb::KeyValue& kv : read.value().kvs()) {
    fresh[kv.key().substr(prefix_.size())] = {Split(kv.value()), kv.mod_revision()};
  }
  std::lock_guard lock(mutex_);
  // What was learnt of a later revision than the read stays.
  for (auto& [id, held] : heads_) {
    if (held.revision > revision) fresh[id] = held;
  }
  for (auto it = deleted_.begin(); it != deleted_.end();) {
    it = it->second > revision ? (fresh.erase(it->first), std::next(it)) : deleted_.erase(it);
  }
  heads_ = std::move(fresh);
  read_ = true;
  read_once_.notify_all();
  return revision;
}

bool EtcdMapHeads::WaitUntilRead(std::chrono::steady_clock::duration timeout) const {
  std::unique_lock lock(mutex_);
  return read_once_.wait_for(lock, timeout, [this] { return read_; });
}

Result<MapHeads::Head> EtcdMapHeads::Read(const std::string& id) const {
  std::lock_guard lock(mutex_);
  if (!read_) return NotReadYet(*client_);
  const auto held = heads_.find(id);
  if (held == heads_.end()) return Head();
  return Head(held->second.versions);
}

Result<std::vector<std::string>> EtcdMapHeads::Ids() const {
  std::lock_guard lock(mutex_);
  if (!read_) return NotReadYet(*client_);
  std::vector<std::string> ids;
  for (const auto& [id, held] : heads_) ids.push_back(id);
  return ids;
}

Result<bool> EtcdMapHeads::Swap(const std::string& id, const Head& expected, const Head& next) {
  const std::string key = prefix_ + id;
  etcdserverpb::TxnRequest txn;
  etcdserverpb::Compare* same = txn.add_compare();
  same->set_key(key);
  same->set_result(etcdserverpb::Compare::EQUAL);
  if (expected) {
    same->set_target(etcdserverpb::Compare::VALUE);
    same->set_value(Join(*expected));
  } else {
    same->set_target(etcdserverpb::Compare::CREATE);  // 0: the key does not exist.
    same->set_create_revision(0);
  }
  if (next) {
    etcdserverpb::PutRequest* put = txn.add_success()->mutable_request_put();
    put->set_key(key);
    put->set_value(Join(*next));
  } else {
    txn.add_success()->mutable_request_delete_range()->set_key(key);
  }
  txn.add_failure()->mutable_request_range()->set_key(key);
  Result<etcdserverpb::TxnResponse> response = client_->Txn(txn);
  if (!response.ok()) {
    ServiceError error = std::move(response).error();
    error.code = ServiceErrorCode::kMapStoreUnavailable;
    return error;
  }
  const std::int64_t revision = response.value().header().revision();
  if (response.value().succeeded()) {
    Apply(id, next, revision);  // This replica reads its own write at once.
    return true;
  }
  // Lost: take the head as it is now, so that the caller decides again on it.
  const etcdserverpb::RangeResponse& current = response.value().responses(0).response_range();
  if (current.kvs_size() == 0) {
    Apply(id, Head(), revision);
  } else {
    Apply(id, Head(Split(current.kvs(0).value())), current.kvs(0).mod_revision());
  }
  return false;
}

}  // namespace strata::server
