#pragma once
/// strata-server's configuration: command-line flags (parsed with CLI11), each with an
/// environment variable: STRATA_ and the flag's name in upper case, dashes as underscores
/// (--map-root and STRATA_MAP_ROOT). A flag overrides its variable. Every default is the
/// initial value of a ServerConfig field below (--preload's is kDefaultPreload); every flag's
/// meaning and range is written once, in ops/flags.cpp; --help prints them, and
/// tests/server/flags_test.cpp checks server/README.md's table against them.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "strata/fleet/motion_conflict.hpp"
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

/// What strata-server runs with. Each field is the flag named beside it (and its variable):
/// what the flag means, its unit and its range are written once, in the flag table of
/// ops/flags.cpp, which --help prints and server/README.md's table repeats (tested). The
/// initial values are the defaults.
struct ServerConfig {
  std::string listen = "0.0.0.0:50051";       ///< --listen
  bool reuse_port = false;                    ///< --reuse-port
  bool exit_on_preload_failure = false;       ///< --exit-on-preload-failure
  int metrics_port = 9090;                    ///< --metrics-port (negative: none)
  std::string metrics_address = "127.0.0.1";  ///< --metrics-address
  int http_port = -1;                         ///< --http-port (negative: none)
  std::string http_address = "0.0.0.0";       ///< --http-address
  std::string map_root;                       ///< --map-root (empty: no file maps)
  /// --preload, else kDefaultPreload; none with --no-preload.
  std::vector<PreloadSpec> preload;
  int max_concurrent_assessments = 1;  ///< --max-concurrent-assessments
  int assessment_threads = 0;          ///< --assessment-threads (0: every core)
  std::uint64_t max_assessment_memory_bytes = std::uint64_t{4} << 30;  ///< --max-assessment-memory
  double max_assessment_time_s = 600.0;                                ///< --max-assessment-time-s
  std::string map_worker;              ///< --map-worker (empty: the one beside the server)
  int max_maps = 16;                   ///< --max-maps
  std::string map_store;               ///< --map-store (empty: maps in memory only)
  std::uint64_t max_memory_bytes = 0;  ///< --max-memory (0: AutomaticMemoryLimit())
  std::uint64_t max_graph_memory_bytes = std::uint64_t{1} << 30;  ///< --max-graph-memory
  int map_versions_kept = 5;                                      ///< --map-versions-kept
  int max_concurrent_plans = 0;               ///< --max-concurrent-plans (0: one per core)
  int max_queued_plans = 256;                 ///< --max-queued-plans
  double max_plan_time_s = 10.0;              ///< --max-plan-time-s
  int max_cost_cells = 10000;                 ///< --max-cost-cells
  int max_batch_plans = 5000;                 ///< --max-batch-plans
  int max_reservations = 1000;                ///< --max-reservations (per map)
  double default_lease_s = 60.0;              ///< --default-lease-s
  double max_lease_s = 3600.0;                ///< --max-lease-s
  double max_reservation_horizon_s = 3600.0;  ///< --max-reservation-horizon-s
  double separation_m = SeparationRule{}.separation_m;  ///< --separation-m
  std::size_t max_points = 50'000'000;                  ///< --max-points
  int max_receive_message_bytes = 4 << 20;              ///< --max-receive-message-bytes
  int max_send_message_bytes = 16 << 20;                ///< --max-send-message-bytes
  double drain_delay_s = 0.0;                           ///< --drain-delay-s
  double shutdown_grace_s = 10.0;                       ///< --shutdown-grace-s
  double keepalive_time_s = 20.0;                       ///< --keepalive-time-s
  double keepalive_timeout_s = 10.0;                    ///< --keepalive-timeout-s
  double max_connection_age_s = 300.0;                  ///< --max-connection-age-s (0: none)
  std::string tls_cert;                  ///< --tls-cert (empty, with tls_key: plaintext)
  std::string tls_key;                   ///< --tls-key
  std::string tls_client_ca;             ///< --tls-client-ca (empty: no client certificates)
  std::string auth_tokens;               ///< --auth-tokens (empty: every call allowed)
  std::string etcd;                      ///< --etcd (empty: this process's memory only)
  std::string etcd_prefix = "/strata";   ///< --etcd-prefix
  std::string etcd_ca;                   ///< --etcd-ca
  std::string etcd_cert;                 ///< --etcd-cert
  std::string etcd_key;                  ///< --etcd-key
  LogLevel log_level = LogLevel::kInfo;  ///< --log-level
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
  std::string placeholder;   ///< "DIR"; empty for a switch.
  std::string default_text;  ///< As --help prints it; empty for none (a switch, --map-root).
  std::string range;         ///< The values it takes ("1 to 64", "> 0"); empty when any.
  std::string env;           ///< "STRATA_MAP_ROOT".
};
/// Every flag but --help and --version, in --help's order.
std::vector<FlagInfo> DescribeFlags();

/// `ID=SOURCE[,KEY=VALUE...]`; the error names the problem.
std::optional<PreloadSpec> ParsePreloadSpec(const std::string& text, std::string* error);

/// The --help text.
std::string UsageText();

}  // namespace strata::server
