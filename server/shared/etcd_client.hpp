#pragma once
/// A minimal client of etcd v3's gRPC API (proto/etcd/): the calls the shared schedule makes,
/// and a watch that follows a key prefix from a revision. Every failure to reach etcd is
/// kSharedStateUnavailable with a message naming the endpoints and gRPC's reason.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "common/service_error.hpp"
#include "etcd/etcdserverpb/rpc.grpc.pb.h"

namespace strata::server {

struct EtcdOptions {
  /// --etcd: host:port of each member; calls go to the first that answers.
  std::vector<std::string> endpoints;
  /// --etcd-ca, --etcd-cert, --etcd-key: TLS to etcd (a CA for its certificate, and a client
  /// certificate and key where etcd asks for one); all empty for plaintext.
  std::string ca_file;
  std::string cert_file;
  std::string key_file;
  /// How long one call may take before etcd counts as unreachable [s].
  double call_timeout_s = 2;

  /// The endpoints from --etcd's comma-separated text; kInvalidInput naming the flag for an
  /// empty list or an entry without a port.
  static Result<std::vector<std::string>> ParseEndpoints(const std::string& text);
};

/// The end of the range of every key that starts with `prefix` (etcd's prefix convention).
std::string PrefixRangeEnd(const std::string& prefix);

class EtcdClient {
 public:
  /// Channels to every endpoint (no call is made: etcd may come up later). kInvalidInput when
  /// a TLS file cannot be read.
  static Result<std::unique_ptr<EtcdClient>> Create(const EtcdOptions& options);

  Result<etcdserverpb::TxnResponse> Txn(const etcdserverpb::TxnRequest& request);
  /// Every key under `prefix` at `revision` (<= 0: the newest).
  Result<etcdserverpb::RangeResponse> RangePrefix(const std::string& prefix,
                                                  std::int64_t revision = 0);
  /// A lease of `ttl_s` seconds; returns its id.
  Result<std::int64_t> GrantLease(std::int64_t ttl_s);
  /// Drops the store's history before `revision` (an operator's or a test's call).
  ServiceStatus Compact(std::int64_t revision);

  /// The endpoints as --etcd gave them, for messages.
  const std::string& endpoints_text() const { return endpoints_text_; }
  /// The channel calls now go to (a watch opens its stream there).
  std::shared_ptr<grpc::Channel> channel() const;
  /// The error for a call that could not reach etcd.
  ServiceError Unreachable(const grpc::Status& status) const;

  const EtcdOptions& options() const { return options_; }

 private:
  explicit EtcdClient(EtcdOptions options);
  // Runs `call` on the current endpoint, then on each other one while etcd is unreachable
  // there; the first endpoint that answered stays current.
  struct Member {
    std::shared_ptr<grpc::Channel> channel;
    std::unique_ptr<etcdserverpb::KV::Stub> kv;
    std::unique_ptr<etcdserverpb::Lease::Stub> lease;
  };
  grpc::Status Call(const std::function<grpc::Status(Member&, grpc::ClientContext&)>& call);

  EtcdOptions options_;
  std::string endpoints_text_;
  std::vector<Member> members_;
  std::atomic<std::size_t> current_{0};
};

/// Follows every change under a prefix from a revision on, on a thread of its own, across
/// etcd restarts: a stream that breaks is opened again from the revision after the last one
/// seen; at the start without a revision, and when that revision was compacted away, `resync`
/// reads the prefix afresh and returns the revision it read at.
class EtcdWatch {
 public:
  struct Handlers {
    /// Events, in revision order, and the revision the store was at when they were sent.
    std::function<void(const etcdserverpb::WatchResponse&)> on_response;
    /// Reads the whole prefix afresh; returns its revision, or an error (tried again later).
    std::function<Result<std::int64_t>()> resync;
    /// Whether the stream is open (etcd reachable), on every change.
    std::function<void(bool connected)> on_connection;
  };
  /// Starts following `prefix` from `from_revision` (inclusive; 0: resync first).
  EtcdWatch(EtcdClient* client, std::string prefix, std::int64_t from_revision, Handlers handlers);
  ~EtcdWatch();  // Stops the stream and joins the thread.
  EtcdWatch(const EtcdWatch&) = delete;
  EtcdWatch& operator=(const EtcdWatch&) = delete;

 private:
  void Run();
  // Opens one stream and reads it until it breaks or Stop; returns false once stopping.
  bool FollowOnce();
  void SetConnected(bool connected);

  EtcdClient* const client_;
  const std::string prefix_;
  const Handlers handlers_;
  std::int64_t next_revision_;  // Only the thread touches it.
  std::mutex mutex_;
  std::condition_variable stop_changed_;
  bool stopping_ = false;                // Guarded by mutex_.
  grpc::ClientContext* open_ = nullptr;  // The open stream's context; guarded by mutex_.
  bool connected_ = false;               // Only the thread touches it.
  std::thread thread_;
};

}  // namespace strata::server
