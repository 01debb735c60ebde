#pragma once
/// strata-server's configuration: command-line flags, each with an environment variable
/// (STRATA_ and the flag's name in upper case, dashes as underscores, e.g. --map-root and
/// STRATA_MAP_ROOT). A flag overrides its variable. server/README.md has the table.
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "log.hpp"

namespace strata::server {

/// A map to create at start: `ID=SOURCE[,KEY=VALUE...]`, SOURCE a path under the map root or
/// `scene:NAME[:SEED]`, KEY one of resolution_m, ground_radius_m, max_tilt_rad.
struct PreloadSpec {
  std::string id;
  std::string path;        ///< Set for a file source.
  std::string scene_name;  ///< Set for a scene source.
  std::uint32_t scene_seed = 0;
  std::optional<double> resolution_m;
  std::optional<double> ground_radius_m;
  std::optional<double> max_tilt_rad;
};

struct ServerConfig {
  /// gRPC listen address host:port; port 0 picks a free port (printed at start).
  std::string listen = "0.0.0.0:50051";
  /// Port of the Prometheus /metrics endpoint, on the host of `listen`; 0 picks a free
  /// port, negative disables it.
  int metrics_port = 9090;
  /// Directory map files are confined to; empty disables file maps.
  std::string map_root;
  /// Maps created at start. Without --preload (and without --no-preload): the demo scene,
  /// "demo=scene:two_level_ramp".
  std::vector<PreloadSpec> preload;
  /// Maps assessed at the same time [-], >= 1.
  int max_concurrent_assessments = 1;
  /// Threads of one assessment [-], >= 0; 0 uses every core.
  int assessment_threads = 0;
  /// Maps held at once [-], >= 1.
  int max_maps = 16;
  /// Plans run at the same time [-], >= 0; 0 means one per core. More wait for a slot
  /// until their deadline.
  int max_concurrent_plans = 0;
  /// Cap on any plan's time budget [s], > 0.
  double max_plan_time_s = 10.0;
  /// Most points one map may hold, from a file or an upload [-], > 0.
  std::size_t max_points = 50'000'000;
  /// Largest request message accepted [bytes], >= 1 MiB + 64 KiB (an upload chunk).
  int max_receive_message_bytes = 4 << 20;
  /// Largest response message sent [bytes], > 0.
  int max_send_message_bytes = 16 << 20;
  /// On SIGTERM/SIGINT, how long in-flight calls may take to finish [s], >= 0.
  double shutdown_grace_s = 10.0;
  /// Keepalive ping period on idle connections [s], > 0.
  double keepalive_time_s = 20.0;
  /// Keepalive ping timeout before the connection is closed [s], > 0.
  double keepalive_timeout_s = 10.0;
  LogLevel log_level = LogLevel::kInfo;
};

/// What the command line asks for.
struct FlagsOutcome {
  enum class Action { kRun, kHelp, kVersion, kError } action = Action::kRun;
  ServerConfig config;
  std::string error;  ///< For kError: names the flag and the problem.
};

/// Parses argv over the environment (`getenv`, e.g. std::getenv).
FlagsOutcome ParseFlags(int argc, const char* const* argv,
                        const std::function<const char*(const char*)>& getenv);

/// `ID=SOURCE[,KEY=VALUE...]`; the error names the problem.
std::optional<PreloadSpec> ParsePreloadSpec(const std::string& text, std::string* error);

/// The --help text.
std::string UsageText();

}  // namespace strata::server
