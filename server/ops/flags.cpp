#include "ops/flags.hpp"

#include "strata/common/parse_numbers.hpp"
#include "strata/version.hpp"

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

namespace strata::server {
namespace {

// The project's version (CMakeLists.txt, through strata/version.hpp), as saved models name it.
const std::string kVersion = std::string("strata-server ") + kStrataVersion + " (API strata.v1)";

// What the flags write: the configuration, and --preload and --no-preload as given.
struct ParsedFlags {
  ServerConfig config;
  std::vector<std::string> preload = {kDefaultPreload};
  bool no_preload = false;
};

// "--map-root" -> "STRATA_MAP_ROOT".
std::string EnvName(const std::string& flag) {
  std::string env = "STRATA_";
  for (const char c : flag.substr(2)) {
    env += c == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  return env;
}

// --help: each flag on one line with its value, default and variable, its description on
// the lines below (CLI11's default layout puts the description beside the flag, which leaves
// too little room for these).
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter() { column_width(6); }  // The description's indent.

  // Each flag's range (Check::range), by name: what --help and DescribeFlags say of it.
  std::map<std::string, std::string> ranges;

  std::string make_option_opts(const CLI::Option* option) const override {
    std::string text;
    std::string notes;
    if (option->get_expected_max() != 0) {  // Not a switch.
      text = " " + option->get_type_name();
      const std::string& fallback = option->get_default_str();
      notes = "default " + (fallback.empty() ? std::string("none") : fallback);
      if (const auto range = ranges.find(option->get_name());
          range != ranges.end() && !range->second.empty() &&
          range->second != option->get_type_name()) {
        notes += ", " + range->second;
      }
    }
    if (!option->get_envname().empty()) {
      notes += (notes.empty() ? "env " : ", env ") + option->get_envname();
    }
    return notes.empty() ? text : text + "  [" + notes + "]";
  }
};

// A flag's check and the values it lets through, said once for --help and the README (CLI11
// prefixes the check's messages with the flag's name).
struct Check {
  CLI::Validator validator;
  std::string range;  // Empty: any value of the flag's kind.
};

Check IntegerIn(long long min, long long max) {
  return {CLI::Range(min, max).description(""),  // The placeholder alone in --help.
          max == std::numeric_limits<long long>::max() ? fmt::format(">= {}", min)
                                                       : fmt::format("{} to {}", min, max)};
}

Check Seconds(bool allow_zero) {
  return {CLI::Validator(
              [allow_zero](std::string& text) {
                const auto value = common::ParseFinite(text);
                if (value && *value >= 0 && (allow_zero || *value > 0)) return std::string();
                return "'" + text + "' is not a number of seconds " + (allow_zero ? ">= 0" : "> 0");
              },
              ""),
          allow_zero ? ">= 0" : "> 0"};
}

Check Meters() {
  return {CLI::Validator(
              [](std::string& text) {
                const auto value = common::ParseFinite(text);
                if (value && *value >= 0) return std::string();
                return "'" + text + "' is not a distance >= 0 in metres";
              },
              ""),
          ">= 0"};
}

Check Switch() {
  return {CLI::IsMember({"1", "0", "true", "false", "yes", "no", "on", "off"}, CLI::ignore_case)
              .description(""),
          ""};
}

Check ExistingFile() { return {CLI::ExistingFile, "an existing file"}; }

Check AnyText() { return {CLI::Validator(), ""}; }

// A host or an IPv4 address, with its port given apart (by `port_flag`).
Check Host(const std::string& port_flag) {
  return {CLI::Validator(
              [port_flag](std::string& text) {
                return text.empty() || text.find(':') != std::string::npos
                           ? "'" + text + "' is not a host or IPv4 address (no port: see " +
                                 port_flag + ")"
                           : std::string();
              },
              ""),
          "a host or IPv4 address"};
}

// Adds the flags to `app`, writing into `parsed`; its formatter (a HelpFormatter) keeps each
// flag's range. With `environment`, every flag also reads its variable; ParseFlags parses the
// command line alone first, so a check that fails then failed on a variable, and its message
// says which.
void AddFlags(CLI::App& app, ParsedFlags& parsed, bool environment) {
  app.description(
      "Serves Strata's gRPC API (strata.v1.MapService, strata.v1.PlannerService, health,\n"
      "reflection), Prometheus metrics and, with --http-port, a web viewer. Every flag can\n"
      "also be set by the environment variable shown with it; a flag overrides its variable.");
  auto formatter = std::make_shared<HelpFormatter>();
  app.formatter(formatter);
  app.set_help_flag("-h,--help", "print this help and exit");
  app.set_version_flag("--version", kVersion, "print the version and exit");

  auto finish = [environment, formatter](CLI::Option* option, const std::string& name,
                                         const Check& checked) {
    formatter->ranges[name] = checked.range;
    CLI::Validator check = checked.validator;
    if (environment) {
      const std::string env = EnvName(name);
      option->envname(env);
      check = CLI::Validator(
          [check, env](std::string& text) {
            const std::string problem = check(text);
            return problem.empty() ? problem : problem + " (from " + env + ")";
          },
          "");
    }
    option->check(std::move(check));
  };
  auto add = [&](const std::string& name, auto& value, const char* placeholder, const char* help,
                 const Check& check) {
    finish(app.add_option(name, value, help)->type_name(placeholder)->capture_default_str(), name,
           check);
  };
  ServerConfig& config = parsed.config;
  add("--listen", config.listen, "HOST:PORT",
      "gRPC listen address; port 0 picks a free port, printed on the 'listening on' line",
      Check{CLI::Validator(
                [](std::string& text) {
                  return text.find(':') == std::string::npos ? "'" + text + "' is not HOST:PORT"
                                                             : std::string();
                },
                ""),
            "HOST:PORT"});
  CLI::Option* reuse_port = app.add_flag(
      "--reuse-port", config.reuse_port,
      "share --listen's port with other processes that ask for it too (SO_REUSEPORT: the\n"
      "kernel splits new connections between them); without it a port in use is an error");
  finish(reuse_port, "--reuse-port", Switch());
  CLI::Option* exit_on_preload_failure = app.add_flag(
      "--exit-on-preload-failure", config.exit_on_preload_failure,
      "exit 1 as soon as a preloaded map fails (so that an orchestrator restarts or reports\n"
      "the pod at once); without it the server keeps serving, NOT_SERVING");
  finish(exit_on_preload_failure, "--exit-on-preload-failure", Switch());
  add("--metrics-port", config.metrics_port, "PORT",
      "Prometheus /metrics HTTP port, on --metrics-address; 0 picks a free port,\n"
      "-1 disables metrics",
      IntegerIn(-1, 65535));
  add("--metrics-address", config.metrics_address, "HOST",
      "address /metrics is served on; metrics carry no token, so the default serves this\n"
      "machine only: 0.0.0.0 for a scraper elsewhere (Kubernetes)",
      Host("--metrics-port"));
  add("--http-port", config.http_port, "PORT",
      "web viewer and its JSON API (plain HTTP), on --http-address; 0 picks a free port,\n"
      "-1 disables it",
      IntegerIn(-1, 65535));
  add("--http-address", config.http_address, "HOST",
      "address the viewer is served on; it answers what gRPC answers, under the same tokens,\n"
      "so by default wherever gRPC is: 127.0.0.1 keeps it to this machine (required with\n"
      "--tls-cert: the viewer has no HTTPS)",
      Host("--http-port"));
  add("--map-root", config.map_root, "DIR",
      "directory map files are loaded from; paths outside it are refused; none: file maps\n"
      "are disabled",
      AnyText());

  CLI::Option* preload =
      app.add_option("--preload", parsed.preload,
                     "map to create at start, repeatable; SOURCE a path under the map root or\n"
                     "scene:NAME[:SEED][:size_m=M][:spacing_m=M]; KEY resolution_m,\n"
                     "ground_radius_m or max_tilt_rad. The environment variable takes a\n"
                     "space-separated list")
          ->type_name("ID=SOURCE[,KEY=VALUE...]")
          ->default_str(kDefaultPreload)
          ->delimiter(' ')
          ->allow_extra_args(false);  // One map per --preload.
  finish(preload, "--preload",
         Check{CLI::Validator(
                   [](std::string& text) {
                     std::string error;
                     return ParsePreloadSpec(text, &error) ? std::string() : error;
                   },
                   ""),
               ""});
  CLI::Option* no_preload = app.add_flag("--no-preload", parsed.no_preload,
                                         "start without any map (not even the demo scene)");
  finish(no_preload, "--no-preload", Switch());
  // Both on the command line contradict each other; from the environment, see ParseFlags.
  if (!environment) no_preload->excludes(preload);

  add("--max-concurrent-assessments", config.max_concurrent_assessments, "N",
      "maps assessed at the same time, off the RPC threads", IntegerIn(1, 64));
  add("--assessment-threads", config.assessment_threads, "N",
      "threads of one assessment; 0 = every core", IntegerIn(0, 1024));
  add("--max-assessment-memory", config.max_assessment_memory_bytes, "BYTES",
      "memory the making of one map may allocate (its worker process's limit); beyond it\n"
      "the map fails with RESOURCE_EXHAUSTED",
      IntegerIn(64 << 20, std::numeric_limits<long long>::max()));
  add("--max-assessment-time-s", config.max_assessment_time_s, "S",
      "seconds the making of one map may take, reading its source included; beyond them\n"
      "the map fails with DEADLINE_EXCEEDED",
      Seconds(false));
  add("--map-worker", config.map_worker, "FILE",
      "the strata-map-worker program each new map is made in; none: the one installed\n"
      "beside strata-server",
      ExistingFile());
  add("--max-maps", config.max_maps, "N",
      "maps held at once, in any state; with --map-store, maps being created or failed here",
      IntegerIn(1, 100000));
  add("--tls-cert", config.tls_cert, "FILE",
      "TLS: the server's certificate chain (PEM); with --tls-key. None serves plaintext",
      ExistingFile());
  add("--tls-key", config.tls_key, "FILE", "TLS: the server's private key (PEM); with --tls-cert",
      ExistingFile());
  add("--tls-client-ca", config.tls_client_ca, "FILE",
      "mutual TLS: clients must present a certificate signed by a CA in this PEM file",
      ExistingFile());
  add("--auth-tokens", config.auth_tokens, "FILE",
      "bearer tokens, one `TOKEN ROLE` a line (ROLE planner: plan and read maps; admin: also\n"
      "create, upload, update and delete maps); none lets every client make every call",
      ExistingFile());
  add("--etcd", config.etcd, "ENDPOINTS",
      "etcd members, host:port separated by commas, that hold the fleet's reservations for\n"
      "every replica started with the same list; none keeps them in this process only",
      AnyText());
  add("--etcd-prefix", config.etcd_prefix, "KEY",
      "the keys under which this deployment's shared state lives in etcd", AnyText());
  add("--etcd-ca", config.etcd_ca, "FILE",
      "TLS to etcd: the CA (PEM) that signed its certificate; none speaks plaintext unless\n"
      "--etcd-cert is given",
      ExistingFile());
  add("--etcd-cert", config.etcd_cert, "FILE",
      "TLS to etcd: this server's client certificate (PEM); with --etcd-key", ExistingFile());
  add("--etcd-key", config.etcd_key, "FILE", "TLS to etcd: the client certificate's key (PEM)",
      ExistingFile());
  add("--map-store", config.map_store, "DIR",
      "map store shared by every replica (a ReadWriteMany volume in Kubernetes): maps are\n"
      "written there as immutable versions and loaded on demand; none keeps maps in memory",
      AnyText());
  add("--max-memory", config.max_memory_bytes, "BYTES",
      "the server's memory budget: maps held, uploads and maps waiting, and\n"
      "--max-assessment-memory for each map being made; work past it is refused with\n"
      "RESOURCE_EXHAUSTED. With --map-store, unused maps are dropped from memory first.\n"
      "0 = 80 % of the memory of the server's cgroup, else of the machine",
      IntegerIn(0, std::numeric_limits<long long>::max()));
  add("--max-graph-memory", config.max_graph_memory_bytes, "BYTES",
      "traversability graphs kept per map (one per robot profile planned with); the least\n"
      "recently used are dropped past it; 0 = no bound",
      IntegerIn(0, std::numeric_limits<long long>::max()));
  add("--map-versions-kept", config.map_versions_kept, "N",
      "with --map-store, versions kept per map (the current one included)", IntegerIn(1, 1000));
  add("--max-concurrent-plans", config.max_concurrent_plans, "N",
      "plans run at the same time; more wait for a slot, first come first served, until\n"
      "their deadline; 0 = one per core",
      IntegerIn(0, 10000));
  add("--max-queued-plans", config.max_queued_plans, "N",
      "plans waiting for a slot at most; more are refused at once with SERVER_BUSY",
      IntegerIn(0, 100000));
  add("--max-plan-time-s", config.max_plan_time_s, "S",
      "cap on every plan's time budget in seconds", Seconds(false));
  add("--max-cost-cells", config.max_cost_cells, "N",
      "most cells (starts x goals) one EstimateCosts call may ask for; more are refused with\n"
      "RESOURCE_EXHAUSTED",
      IntegerIn(1, 10'000'000));
  add("--max-batch-plans", config.max_batch_plans, "N",
      "most plans one PlanBatch call may hold; more are refused with RESOURCE_EXHAUSTED",
      IntegerIn(1, 1'000'000));
  add("--max-reservations", config.max_reservations, "N",
      "most robots' reservations one map may hold; more are refused with RESOURCE_EXHAUSTED",
      IntegerIn(1, 1'000'000));
  add("--default-lease-s", config.default_lease_s, "S",
      "how long a reservation holds its robot's goal from when it is made, unless the\n"
      "request says (it always holds until the robot arrives)",
      Seconds(false));
  add("--max-lease-s", config.max_lease_s, "S", "longest lease a request may ask for",
      Seconds(false));
  add("--max-reservation-horizon-s", config.max_reservation_horizon_s, "S",
      "how far ahead of now a reserved trajectory may start", Seconds(false));
  add("--separation-m", config.separation_m, "M",
      "free distance kept between two robots' bodies, unless the request says", Meters());
  add("--max-points", config.max_points, "N", "most points one map may hold, file or upload",
      IntegerIn(1, std::numeric_limits<long long>::max()));
  add("--max-receive-message-bytes", config.max_receive_message_bytes, "N",
      "largest request message accepted; at least 1114112, an upload chunk of 1 MiB plus\n"
      "framing",
      IntegerIn((1 << 20) + (64 << 10), 1 << 30));
  add("--max-send-message-bytes", config.max_send_message_bytes, "N",
      "largest response message sent", IntegerIn(1 << 16, 1 << 30));
  add("--drain-delay-s", config.drain_delay_s, "S",
      "on SIGTERM, seconds health reports NOT_SERVING while new calls are still accepted\n"
      "(for load balancers to stop sending); SIGINT skips it",
      Seconds(true));
  add("--shutdown-grace-s", config.shutdown_grace_s, "S",
      "then seconds in-flight calls may take to finish; plans still running stop and\n"
      "answer SHUTTING_DOWN",
      Seconds(true));
  add("--keepalive-time-s", config.keepalive_time_s, "S",
      "keepalive ping period on idle connections, in seconds", Seconds(false));
  add("--keepalive-timeout-s", config.keepalive_timeout_s, "S",
      "seconds to wait for a keepalive ack before closing the connection", Seconds(false));
  add("--max-connection-age-s", config.max_connection_age_s, "S",
      "seconds after which a client's connection is asked to reconnect (calls in flight\n"
      "finish first), so that replicas added by a scale-out get calls too; 0 = never",
      Seconds(true));
  finish(app.add_option_function<std::string>(
                "--log-level",
                [&config](const std::string& text) { ParseLogLevel(text, &config.log_level); },
                "how much the server logs: each level and those above it")
             ->type_name("LEVEL")
             ->default_str(LogLevelName(config.log_level)),
         "--log-level",
         Check{CLI::Validator(
                   [](std::string& text) {
                     LogLevel level;
                     return ParseLogLevel(text, &level) ? std::string()
                                                        : "'" + text + "' is not a log level";
                   },
                   ""),
               "debug, info, warning, error"});
}

}  // namespace

std::optional<PreloadSpec> ParsePreloadSpec(const std::string& text, std::string* error) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
    *error = "preload '" + text + "' is not ID=SOURCE (e.g. demo=scene:two_level_ramp)";
    return std::nullopt;
  }
  PreloadSpec spec;
  spec.id = text.substr(0, eq);
  std::vector<std::string> parts;
  std::istringstream rest(text.substr(eq + 1));
  for (std::string part; std::getline(rest, part, ',');) parts.push_back(part);
  const std::string& source = parts.front();
  if (source.starts_with(kScenePrefix)) {
    Expected<SceneSource> scene = ParseSceneSource(source);
    if (!scene) {
      *error = "preload '" + text + "': " + scene.error().message;
      return std::nullopt;
    }
    spec.scene = std::move(scene).value();
  } else {
    spec.path = source;
  }
  for (std::size_t i = 1; i < parts.size(); ++i) {
    const std::size_t kv = parts[i].find('=');
    const std::string key = parts[i].substr(0, kv);
    const auto value =
        kv == std::string::npos ? std::nullopt : common::ParseFinite(parts[i].substr(kv + 1));
    std::optional<double>* slot = key == "resolution_m"      ? &spec.resolution_m
                                  : key == "ground_radius_m" ? &spec.ground_radius_m
                                  : key == "max_tilt_rad"    ? &spec.max_tilt_rad
                                                             : nullptr;
    if (slot == nullptr || !value) {
      *error = "preload '" + text + "': '" + parts[i] +
               "' is not KEY=NUMBER with KEY resolution_m, ground_radius_m or max_tilt_rad";
      return std::nullopt;
    }
    *slot = value;
  }
  return spec;
}

FlagsOutcome ParseFlags(int argc, const char* const* argv) {
  FlagsOutcome outcome;
  auto fail = [&outcome](std::string message) {
    outcome.action = FlagsOutcome::Action::kError;
    outcome.text = std::move(message);
    return outcome;
  };
  // The command line alone first, so that its errors name flags, not variables.
  ParsedFlags line;
  CLI::App line_app("", "strata-server");
  AddFlags(line_app, line, /*environment=*/false);
  try {
    line_app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    outcome.action = FlagsOutcome::Action::kHelp;
    outcome.text = UsageText();
    return outcome;
  } catch (const CLI::CallForVersion& version) {
    outcome.action = FlagsOutcome::Action::kVersion;
    outcome.text = std::string(version.what()) + "\n";
    return outcome;
  } catch (const CLI::ParseError& error) {
    return fail(std::string(error.what()) + " (strata-server --help lists the flags)");
  }
  // Then over the environment: only a variable can fail now, and its check names it.
  ParsedFlags parsed;
  CLI::App app("", "strata-server");
  AddFlags(app, parsed, /*environment=*/true);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return fail(error.what());
  }
  // --preload on the command line beats STRATA_NO_PRELOAD as it beats STRATA_PRELOAD;
  // --no-preload (or its variable) beats STRATA_PRELOAD.
  const bool preload_given = line_app.get_option("--preload")->count() > 0;
  if (parsed.no_preload && !preload_given) parsed.preload.clear();
  outcome.config = parsed.config;
  if (outcome.config.default_lease_s > outcome.config.max_lease_s) {
    return fail(
        fmt::format("--default-lease-s {:g} exceeds --max-lease-s {:g}: raise the "
                    "second or lower the first",
                    outcome.config.default_lease_s, outcome.config.max_lease_s));
  }
  for (const std::string& text : parsed.preload) {
    std::string error;
    std::optional<PreloadSpec> spec = ParsePreloadSpec(text, &error);
    if (!spec) return fail(error);  // Only kDefaultPreload is not checked by the flag.
    outcome.config.preload.push_back(std::move(*spec));
  }
  return outcome;
}

std::vector<FlagInfo> DescribeFlags() {
  ParsedFlags defaults;
  CLI::App app("", "strata-server");
  AddFlags(app, defaults, /*environment=*/true);
  const auto& ranges = std::static_pointer_cast<HelpFormatter>(app.get_formatter())->ranges;
  std::vector<FlagInfo> flags;
  for (const CLI::Option* option : app.get_options()) {
    if (option == app.get_help_ptr() || option == app.get_version_ptr()) continue;
    const bool takes_value = option->get_expected_max() != 0;
    flags.push_back({option->get_name(), takes_value ? option->get_type_name() : std::string(),
                     option->get_default_str(), ranges.at(option->get_name()),
                     option->get_envname()});
  }
  return flags;
}

std::string UsageText() {
  ParsedFlags defaults;
  CLI::App app("", "strata-server");
  AddFlags(app, defaults, /*environment=*/true);
  return app.help();
}

}  // namespace strata::server
