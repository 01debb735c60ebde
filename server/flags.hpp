#pragma once
/// strata-server's configuration: command-line flags (parsed with CLI11), each with an
/// environment variable: STRATA_ and the flag's name in upper case, dashes as underscores
/// (--map-root and STRATA_MAP_ROOT). A flag overrides its variable. Every default is the
/// initial value of a ServerConfig field below (--preload's is kDefaultPreload); --help prints
/// them, and tests/server/flags_test.cpp checks that server/README.md and README.md agree.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "log.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::server {

/// A map to create at start: `ID=SOURCE[,KEY=VALUE...]`, SOURCE a path under the map root or
/// `scene:NAME[:SEED][:size_m=M][:spacing_m=M]` (strata::ParseSceneSource), KEY one of
/// resolution_m, ground_radius_m, max_tilt_rad.
struct PreloadSpec {
  std::string id;
  std::string path;                  ///< Set for a file source.
  std::optional<SceneSource> scene;  ///< Set for a scene source.
  std::optional<double> resolution_m;
  std::optional<double> ground_radius_m;
  std::optional<double> max_tilt_rad;
};

/// --preload's default, the demo scene; --no-preload starts without it.
inline constexpr const char* kDefaultPreload = "demo=scene:two_level_ramp";

/// Most trajectory samples one PlanResponse may carry (options.sample_dt_s): 20,000 samples
/// of 4 vectors are about 2 MB, well under --max-send-message-bytes' default.
inline constexpr int kMaxResponseSamples = 20000;

struct ServerConfig {
  /// gRPC listen address host:port; port 0 picks a free port (printed at start).
  std::string listen = "0.0.0.0:50051";
  /// Let other processes listen on the same port too (SO_REUSEPORT: the kernel splits new
  /// connections between them). Off, a port another process listens on is an error at start.
  bool reuse_port = false;
  /// Port of the Prometheus /metrics endpoint, on metrics_address; 0 picks a free port,
  /// negative disables it.
  int metrics_port = 9090;
  /// Address (host or IP) /metrics is served on. Metrics carry no token, so by default only
  /// this machine reaches them; a scraper elsewhere (Kubernetes) needs 0.0.0.0.
  std::string metrics_address = "127.0.0.1";
  /// Port of the web viewer and its JSON API (plain HTTP), on http_address; 0 picks a free
  /// port (printed at start), negative disables it.
  int http_port = -1;
  /// Address (host or IP) the viewer is served on. It answers only what the gRPC API answers,
  /// under the same tokens, so by default it is reachable wherever gRPC is (unlike /metrics,
  /// which carries no token); 127.0.0.1 keeps it to this machine, and with tls_cert it must be
  /// a loopback address (server/http_server.hpp: the viewer has no HTTPS).
  std::string http_address = "0.0.0.0";
  /// Directory map files are confined to; empty disables file maps.
  std::string map_root;
  /// Maps created at start: --preload, else kDefaultPreload; none with --no-preload.
  std::vector<PreloadSpec> preload;
  /// Maps assessed at the same time [-], >= 1.
  int max_concurrent_assessments = 1;
  /// Threads of one assessment [-], >= 0; 0 uses every core.
  int assessment_threads = 0;
  /// Memory the making of one map may allocate, its worker process's limit [bytes],
  /// >= 64 MiB. The server's memory budget sets this much aside while a map is made.
  std::uint64_t max_assessment_memory_bytes = std::uint64_t{4} << 30;
  /// Longest the making of one map may take, reading its source included [s], > 0.
  double max_assessment_time_s = 600.0;
  /// The strata-map-worker program (server/map_worker.hpp); empty: the one beside the
  /// running strata-server.
  std::string map_worker;
  /// Maps held at once [-], >= 1. With a map store: maps being created or failed on this
  /// server (the store's maps are loaded on demand, bounded by max_memory_bytes).
  int max_maps = 16;
  /// Directory of the map store shared by every replica (server/map_store.hpp); empty keeps
  /// maps in this server's memory only.
  std::string map_store;
  /// The server's memory budget [bytes], >= 0: maps held (models and graphs), uploads being
  /// received and maps waiting to be made, and max_assessment_memory_bytes for each map being
  /// made or edited. 0: AutomaticMemoryLimit() (80 % of the cgroup's or the machine's memory).
  std::uint64_t max_memory_bytes = 0;
  /// Traversability graphs kept per map [bytes], >= 0; 0 = no bound. One graph per robot
  /// profile planned with; past it, the least recently used no plan holds are dropped.
  std::uint64_t max_graph_memory_bytes = std::uint64_t{1} << 30;
  /// With a map store: versions kept per map, the current one included [-], >= 1.
  int map_versions_kept = 5;
  /// Plans run at the same time [-], >= 0; 0 means one per core. More wait for a slot, first
  /// come first served, until their deadline.
  int max_concurrent_plans = 0;
  /// Plans waiting for a slot at most [-], >= 0; a plan beyond them is refused at once with
  /// SERVER_BUSY (a burst of thousands of calls must not hold thousands of threads).
  int max_queued_plans = 256;
  /// Cap on any plan's time budget [s], > 0 (and on any travel-cost estimate's).
  double max_plan_time_s = 10.0;
  /// Most cells (starts × goals) one EstimateCosts call may ask for [-], >= 1. 10,000 keeps
  /// the largest response (every end off the ground, each with its message) under gRPC's
  /// default 4 MiB client limit.
  int max_cost_cells = 10000;
  /// Most plans one PlanBatch call may hold [-], >= 1.
  int max_batch_plans = 5000;
  /// Most points one map may hold, from a file or an upload [-], > 0.
  std::size_t max_points = 50'000'000;
  /// Largest request message accepted [bytes], >= 1 MiB + 64 KiB (an upload chunk).
  int max_receive_message_bytes = 4 << 20;
  /// Largest response message sent [bytes], > 0.
  int max_send_message_bytes = 16 << 20;
  /// On SIGTERM, how long health reports NOT_SERVING while new calls are still accepted,
  /// before the server stops accepting [s], >= 0: the time a load balancer (Kubernetes'
  /// endpoints) needs to stop sending calls here. SIGINT skips it.
  double drain_delay_s = 0.0;
  /// Then how long in-flight calls may take to finish [s], >= 0; plans still running at its
  /// end stop and answer UNAVAILABLE with reason SHUTTING_DOWN.
  double shutdown_grace_s = 10.0;
  /// Keepalive ping period on idle connections [s], > 0.
  double keepalive_time_s = 20.0;
  /// Keepalive ping timeout before the connection is closed [s], > 0.
  double keepalive_timeout_s = 10.0;
  /// TLS: the server's certificate chain and private key (PEM files); both or neither. Empty
  /// serves plaintext.
  std::string tls_cert;
  std::string tls_key;
  /// Mutual TLS: clients must present a certificate signed by a CA in this PEM file.
  std::string tls_client_ca;
  /// Bearer tokens with roles (server/auth.hpp); empty lets every client make every call.
  std::string auth_tokens;
  LogLevel log_level = LogLevel::kInfo;
};

/// What the command line asks for.
struct FlagsOutcome {
  enum class Action { kRun, kHelp, kVersion, kError } action = Action::kRun;
  ServerConfig config;  ///< For kRun.
  /// For kHelp the --help text and for kVersion the version (each ending in a newline); for
  /// kError the problem, naming the flag, or the variable when the value came from it.
  std::string text;
};

/// Parses argv over the process environment: a flag's variable applies where the flag is not
/// on the command line. Exits nothing and prints nothing.
FlagsOutcome ParseFlags(int argc, const char* const* argv);

/// One flag as --help shows it.
struct FlagInfo {
  std::string name;          ///< "--map-root".
  std::string default_text;  ///< As --help prints it; empty for none (a switch, --map-root).
  std::string env;           ///< "STRATA_MAP_ROOT".
};
/// Every flag but --help and --version, in --help's order.
std::vector<FlagInfo> DescribeFlags();

/// `ID=SOURCE[,KEY=VALUE...]`; the error names the problem.
std::optional<PreloadSpec> ParsePreloadSpec(const std::string& text, std::string* error);

/// The --help text.
std::string UsageText();

}  // namespace strata::server
