#pragma once
/// The map store's heads on etcd (--etcd with --map-store): key <prefix>/heads/<map id>, whose
/// value is the map's kept versions, newest first, one per line. Every replica follows the
/// prefix with a watch into memory, so that a plan reads no head file and no etcd; publishing
/// and deleting are Txns comparing the head's value with the one decided on.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "maps/map_heads.hpp"
#include "shared/etcd_client.hpp"

namespace strata::server {

class EtcdMapHeads final : public MapHeads {
 public:
  /// Starts following the heads (a first read, then the watch). `client` outlives it.
  EtcdMapHeads(EtcdClient* client, const std::string& prefix);
  ~EtcdMapHeads() override;

  Result<Head> Read(const std::string& id) const override;
  Result<std::vector<std::string>> Ids() const override;
  Result<bool> Swap(const std::string& id, const Head& expected, const Head& next) override;

  /// Blocks until the heads were read once (true), or `timeout` passes.
  bool WaitUntilRead(std::chrono::steady_clock::duration timeout) const;

 private:
  struct Held {
    std::vector<std::string> versions;
    std::int64_t revision = 0;  // The etcd revision that wrote it.
  };
  // Sets `id`'s head (nullopt: deleted) as of `revision`, unless something newer is held.
  void Apply(const std::string& id, const Head& head, std::int64_t revision);
  Result<std::int64_t> ReadAll();

  EtcdClient* const client_;
  const std::string prefix_;  // "<prefix>/heads/"
  mutable std::mutex mutex_;
  mutable std::condition_variable read_once_;
  bool read_ = false;                  // Guarded by mutex_.
  std::map<std::string, Held> heads_;  // Guarded by mutex_.
  // Deletions seen, by id: the revision, so that an older put arriving late is ignored.
  std::map<std::string, std::int64_t> deleted_;  // Guarded by mutex_.
  std::unique_ptr<EtcdWatch> watch_;
};

}  // namespace strata::server
