#include "shared/etcd_client.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <utility>

#include <fmt/format.h>

namespace strata::server {
namespace {

// How long a broken watch waits before opening its stream again: etcd restarting, or a
// network outage, is met with one attempt a second rather than a busy loop.
constexpr auto kWatchRetryDelay = std::chrono::seconds(1);

bool ReadWhole(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return static_cast<bool>(in) || in.eof();
}

bool Unreachable(const grpc::Status& status) {
  return status.error_code() == grpc::StatusCode::UNAVAILABLE ||
         status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED;
}

}  // namespace

Result<std::vector<std::string>> EtcdOptions::ParseEndpoints(const std::string& text) {
  std::vector<std::string> endpoints;
  std::stringstream in(text);
  for (std::string endpoint; std::getline(in, endpoint, ',');) {
    endpoint.erase(0, endpoint.find_first_not_of(' '));
    endpoint.erase(endpoint.find_last_not_of(' ') + 1);
    // etcd's own tools take URLs; the scheme is implied by the TLS options here.
    for (const std::string_view scheme : {"http://", "https://"}) {
      if (endpoint.starts_with(scheme)) endpoint.erase(0, scheme.size());
    }
    if (endpoint.empty()) continue;
    const std::size_t colon = endpoint.rfind(':');
    if (colon == std::string::npos || colon + 1 == endpoint.size()) {
      return MakeError(ErrorCode::kInvalidInput,
                       fmt::format("--etcd: {} has no port: give each member as host:port, "
                                   "separated by commas (e.g. etcd-0.etcd:2379,etcd-1.etcd:2379)",
                                   endpoint));
    }
    endpoints.push_back(std::move(endpoint));
  }
  if (endpoints.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--etcd names no endpoint: give host:port of each etcd member");
  }
  return endpoints;
}

std::string PrefixRangeEnd(const std::string& prefix) {
  std::string end = prefix;
  while (!end.empty()) {
    auto& last = reinterpret_cast<unsigned char&>(end.back());
    if (last < 0xff) {
      ++last;
      return end;
    }
    end.pop_back();
  }
  return std::string(1, '\0');  // Every key.
}

EtcdClient::EtcdClient(EtcdOptions options) : options_(std::move(options)) {
  for (const std::string& endpoint : options_.endpoints) {
    endpoints_text_ += (endpoints_text_.empty() ? "" : ",") + endpoint;
  }
}

Result<std::unique_ptr<EtcdClient>> EtcdClient::Create(const EtcdOptions& options) {
  std::unique_ptr<EtcdClient> client(new EtcdClient(options));
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  const bool tls = !options.ca_file.empty() || !options.cert_file.empty();
  if (options.cert_file.empty() != options.key_file.empty()) {
    return MakeError(ErrorCode::kInvalidInput,
                     "--etcd-cert and --etcd-key go together: give both for a client "
                     "certificate, or neither");
  }
  if (tls) {
    grpc::SslCredentialsOptions ssl;
    const std::pair<const char*, const std::string*> files[] = {{"--etcd-ca", &options.ca_file},
                                                                {"--etcd-cert", &options.cert_file},
                                                                {"--etcd-key", &options.key_file}};
    std::string* texts[] = {&ssl.pem_root_certs, &ssl.pem_cert_chain, &ssl.pem_private_key};
    for (int i = 0; i < 3; ++i) {
      if (files[i].second->empty()) continue;
      if (!ReadWhole(*files[i].second, texts[i])) {
        return MakeError(
            ErrorCode::kInvalidInput,
            fmt::format("{} {}: cannot read a PEM file there", files[i].first, *files[i].second));
      }
    }
    credentials = grpc::SslCredentials(ssl);
  }
  grpc::ChannelArguments arguments;
  // Notice a dead member within seconds, and come back quickly when it returns.
  arguments.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 10000);
  arguments.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 5000);
  arguments.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  arguments.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  for (const std::string& endpoint : options.endpoints) {
    Member member;
    member.channel = grpc::CreateCustomChannel(endpoint, credentials, arguments);
    member.kv = etcdserverpb::KV::NewStub(member.channel);
    member.lease = etcdserverpb::Lease::NewStub(member.channel);
    client->members_.push_back(std::move(member));
  }
  return client;
}

std::shared_ptr<grpc::Channel> EtcdClient::channel() const {
  return members_[current_.load() % members_.size()].channel;
}

ServiceError EtcdClient::Unreachable(const grpc::Status& status) const {
  return MakeError(ServiceErrorCode::kSharedStateUnavailable,
                   fmt::format("etcd at {} is unreachable ({}): reservations cannot be "
                               "committed or changed until it answers again; plans that do not "
                               "reserve are still answered",
                               endpoints_text_, status.error_message()));
}

grpc::Status EtcdClient::Call(
    const std::function<grpc::Status(Member&, grpc::ClientContext&)>& call) {
  grpc::Status status;
  const std::size_t first = current_.load();
  for (std::size_t i = 0; i < members_.size(); ++i) {
    const std::size_t index = (first + i) % members_.size();
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::duration_cast<std::chrono::milliseconds>(
                             std::chrono::duration<double>(options_.call_timeout_s)));
    status = call(members_[index], context);
    if (!::strata::server::Unreachable(status)) {
      current_.store(index);
      return status;
    }
  }
  return status;
}

Result<etcdserverpb::TxnResponse> EtcdClient::Txn(const etcdserverpb::TxnRequest& request) {
  etcdserverpb::TxnResponse response;
  const grpc::Status status = Call([&](Member& member, grpc::ClientContext& context) {
    return member.kv->Txn(&context, request, &response);
  });
  if (!status.ok()) return Unreachable(status);
  return response;
}

Result<etcdserverpb::RangeResponse> EtcdClient::RangePrefix(const std::string& prefix,
                                                            std::int64_t revision) {
  etcdserverpb::RangeRequest request;
  request.set_key(prefix);
  request.set_range_end(PrefixRangeEnd(prefix));
  request.set_revision(revision);
  etcdserverpb::RangeResponse response;
  const grpc::Status status = Call([&](Member& member, grpc::ClientContext& context) {
    return member.kv->Range(&context, request, &response);
  });
  if (!status.ok()) return Unreachable(status);
  return response;
}

Result<std::int64_t> EtcdClient::GrantLease(std::int64_t ttl_s) {
  etcdserverpb::LeaseGrantRequest request;
  request.set_ttl(ttl_s);
  etcdserverpb::LeaseGrantResponse response;
  const grpc::Status status = Call([&](Member& member, grpc::ClientContext& context) {
    return member.lease->LeaseGrant(&context, request, &response);
  });
  if (!status.ok()) return Unreachable(status);
  if (!response.error().empty()) {
    return MakeError(ServiceErrorCode::kSharedStateUnavailable,
                     fmt::format("etcd at {} refused a lease of {} s: {}", endpoints_text_, ttl_s,
                                 response.error()));
  }
  return response.id();
}

ServiceStatus EtcdClient::Compact(std::int64_t revision) {
  etcdserverpb::CompactionRequest request;
  request.set_revision(revision);
  request.set_physical(true);
  etcdserverpb::CompactionResponse response;
  const grpc::Status status = Call([&](Member& member, grpc::ClientContext& context) {
    return member.kv->Compact(&context, request, &response);
  });
  if (!status.ok()) return Unreachable(status);
  return OkStatus();
}

EtcdWatch::EtcdWatch(EtcdClient* client, std::string prefix, std::int64_t from_revision,
                     Handlers handlers)
    : client_(client),
      prefix_(std::move(prefix)),
      handlers_(std::move(handlers)),
      next_revision_(from_revision),
      thread_([this] { Run(); }) {}

EtcdWatch::~EtcdWatch() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    if (open_ != nullptr) open_->TryCancel();
  }
  stop_changed_.notify_all();
  thread_.join();
}

void EtcdWatch::SetConnected(bool connected) {
  if (connected == connected_) return;
  connected_ = connected;
  if (handlers_.on_connection) handlers_.on_connection(connected);
}

void EtcdWatch::Run() {
  for (;;) {
    bool following = true;
    if (next_revision_ <= 0) {
      // A first read, or a read afresh after the history was compacted.
      Result<std::int64_t> read_at = handlers_.resync();
      if (read_at.ok()) next_revision_ = read_at.value() + 1;
      following = read_at.ok();
    }
    if (following && !FollowOnce()) return;
    SetConnected(false);
    std::unique_lock lock(mutex_);
    stop_changed_.wait_for(lock, kWatchRetryDelay, [this] { return stopping_; });
    if (stopping_) return;
  }
}

bool EtcdWatch::FollowOnce() {
  grpc::ClientContext context;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    open_ = &context;
  }
  const auto close = [&] {
    std::lock_guard lock(mutex_);
    open_ = nullptr;
    return !stopping_;
  };
  auto stub = etcdserverpb::Watch::NewStub(client_->channel());
  auto stream = stub->Watch(&context);
  etcdserverpb::WatchRequest request;
  etcdserverpb::WatchCreateRequest* create = request.mutable_create_request();
  create->set_key(prefix_);
  create->set_range_end(PrefixRangeEnd(prefix_));
  create->set_start_revision(next_revision_);
  create->set_progress_notify(true);
  if (!stream->Write(request)) {
    stream->Finish();
    return close();
  }
  etcdserverpb::WatchResponse response;
  while (stream->Read(&response)) {
    if (response.canceled()) {
      // What was missed is gone from etcd's history: read everything afresh (Run).
      if (response.compact_revision() > 0) next_revision_ = 0;
      break;
    }
    SetConnected(true);
    for (const mvccpb::Event& event : response.events()) {
      next_revision_ = std::max(next_revision_, event.kv().mod_revision() + 1);
    }
    if (response.events().empty() && !response.created()) {
      // A progress notice: every later event has a higher revision than its header's.
      next_revision_ = std::max(next_revision_, response.header().revision() + 1);
    }
    handlers_.on_response(response);
  }
  context.TryCancel();
  stream->Finish();
  return close();
}

}  // namespace strata::server
