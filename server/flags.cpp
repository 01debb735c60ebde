#include "flags.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

namespace strata::server {
namespace {

using Setter = std::function<std::optional<std::string>(ServerConfig&, const std::string&)>;

struct FlagSpec {
  const char* name;   // Without the leading dashes.
  const char* value;  // Placeholder in --help; nullptr for a switch.
  const char* help;
  Setter set;
};

std::string EnvName(const char* flag) {
  std::string env = "STRATA_";
  for (const char* c = flag; *c != '\0'; ++c) {
    env += *c == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(*c)));
  }
  return env;
}

std::optional<double> ParseDouble(const std::string& text) {
  double value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<long long> ParseInteger(const std::string& text) {
  long long value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

Setter IntFlag(int ServerConfig::*member, long long min, long long max) {
  return [=](ServerConfig& c, const std::string& text) -> std::optional<std::string> {
    const auto value = ParseInteger(text);
    if (!value || *value < min || *value > max) {
      return "'" + text + "' is not an integer in [" + std::to_string(min) + ", " +
             std::to_string(max) + "]";
    }
    c.*member = static_cast<int>(*value);
    return std::nullopt;
  };
}

Setter PositiveSeconds(double ServerConfig::*member, bool allow_zero) {
  return [=](ServerConfig& c, const std::string& text) -> std::optional<std::string> {
    const auto value = ParseDouble(text);
    if (!value || *value < 0 || (!allow_zero && *value == 0)) {
      return "'" + text + "' is not a number of seconds " + (allow_zero ? ">= 0" : "> 0");
    }
    c.*member = *value;
    return std::nullopt;
  };
}

const std::vector<FlagSpec>& Flags() {
  static const std::vector<FlagSpec> flags = {
      {"listen", "HOST:PORT",
       "gRPC listen address (default 0.0.0.0:50051); port 0 picks a free port, printed on the "
       "'listening on' line",
       [](ServerConfig& c, const std::string& v) -> std::optional<std::string> {
         if (v.find(':') == std::string::npos) return "'" + v + "' is not HOST:PORT";
         c.listen = v;
         return std::nullopt;
       }},
      {"metrics-port", "PORT",
       "Prometheus /metrics HTTP port, on the host of --listen (default 9090); 0 picks a free "
       "port, -1 disables metrics",
       IntFlag(&ServerConfig::metrics_port, -1, 65535)},
      {"map-root", "DIR",
       "directory map files are loaded from; paths outside it are refused (default: none, "
       "file maps disabled)",
       [](ServerConfig& c, const std::string& v) -> std::optional<std::string> {
         c.map_root = v;
         return std::nullopt;
       }},
      {"preload", "ID=SOURCE[,KEY=VALUE...]",
       "map to create at start, repeatable; SOURCE a path under the map root or "
       "scene:NAME[:SEED]; KEY resolution_m, ground_radius_m or max_tilt_rad. Default: "
       "demo=scene:two_level_ramp. The environment variable takes a space-separated list",
       [](ServerConfig& c, const std::string& v) -> std::optional<std::string> {
         std::string error;
         std::istringstream words(v);
         std::string word;
         while (words >> word) {
           std::optional<PreloadSpec> spec = ParsePreloadSpec(word, &error);
           if (!spec) return error;
           c.preload.push_back(*spec);
         }
         return std::nullopt;
       }},
      {"no-preload", nullptr, "start without any map (not even the demo scene)",
       [](ServerConfig& c, const std::string&) -> std::optional<std::string> {
         c.preload.clear();
         c.preload.push_back(PreloadSpec{});  // Marker: an explicit empty list.
         return std::nullopt;
       }},
      {"max-concurrent-assessments", "N",
       "maps assessed at the same time, off the RPC threads (default 1)",
       IntFlag(&ServerConfig::max_concurrent_assessments, 1, 64)},
      {"assessment-threads", "N", "threads of one assessment; 0 = every core (default 0)",
       IntFlag(&ServerConfig::assessment_threads, 0, 1024)},
      {"max-maps", "N", "maps held at once, in any state (default 16)",
       IntFlag(&ServerConfig::max_maps, 1, 100000)},
      {"max-concurrent-plans", "N",
       "plans run at the same time; more wait for a slot until their deadline; 0 = one per "
       "core (default 0)",
       IntFlag(&ServerConfig::max_concurrent_plans, 0, 10000)},
      {"max-plan-time-s", "S", "cap on every plan's time budget in seconds (default 10)",
       PositiveSeconds(&ServerConfig::max_plan_time_s, false)},
      {"max-points", "N", "most points one map may hold, file or upload (default 50000000)",
       [](ServerConfig& c, const std::string& v) -> std::optional<std::string> {
         const auto value = ParseInteger(v);
         if (!value || *value < 1) return "'" + v + "' is not a positive integer";
         c.max_points = static_cast<std::size_t>(*value);
         return std::nullopt;
       }},
      {"max-receive-message-bytes", "N",
       "largest request message accepted (default 4194304; at least 1114112, an upload chunk "
       "of 1 MiB plus framing)",
       IntFlag(&ServerConfig::max_receive_message_bytes, (1 << 20) + (64 << 10), 1 << 30)},
      {"max-send-message-bytes", "N", "largest response message sent (default 16777216)",
       IntFlag(&ServerConfig::max_send_message_bytes, 1 << 16, 1 << 30)},
      {"shutdown-grace-s", "S",
       "on SIGTERM/SIGINT, seconds in-flight calls may take to finish before they are "
       "cancelled (default 10)",
       PositiveSeconds(&ServerConfig::shutdown_grace_s, true)},
      {"keepalive-time-s", "S", "keepalive ping period on idle connections (default 20)",
       PositiveSeconds(&ServerConfig::keepalive_time_s, false)},
      {"keepalive-timeout-s", "S",
       "seconds to wait for a keepalive ack before closing the connection (default 10)",
       PositiveSeconds(&ServerConfig::keepalive_timeout_s, false)},
      {"log-level", "LEVEL", "debug, info, warning or error (default info)",
       [](ServerConfig& c, const std::string& v) -> std::optional<std::string> {
         if (!ParseLogLevel(v, &c.log_level)) return "'" + v + "' is not a log level";
         return std::nullopt;
       }},
  };
  return flags;
}

const FlagSpec* FindFlag(const std::string& name) {
  for (const FlagSpec& flag : Flags()) {
    if (name == flag.name) return &flag;
  }
  return nullptr;
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
  if (source.rfind("scene:", 0) == 0) {
    const std::string scene = source.substr(6);
    const std::size_t colon = scene.find(':');
    spec.scene_name = scene.substr(0, colon);
    if (colon != std::string::npos) {
      const auto seed = ParseInteger(scene.substr(colon + 1));
      if (!seed || *seed < 0 || *seed > 0xFFFFFFFFLL) {
        *error = "preload '" + text + "': the seed must be an integer in [0, 4294967295]";
        return std::nullopt;
      }
      spec.scene_seed = static_cast<std::uint32_t>(*seed);
    }
    if (spec.scene_name.empty()) {
      *error = "preload '" + text + "': scene:NAME[:SEED] needs a NAME";
      return std::nullopt;
    }
  } else {
    spec.path = source;
  }
  for (std::size_t i = 1; i < parts.size(); ++i) {
    const std::size_t kv = parts[i].find('=');
    const std::string key = parts[i].substr(0, kv);
    const auto value =
        kv == std::string::npos ? std::nullopt : ParseDouble(parts[i].substr(kv + 1));
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

FlagsOutcome ParseFlags(int argc, const char* const* argv,
                        const std::function<const char*(const char*)>& getenv) {
  FlagsOutcome outcome;
  ServerConfig& config = outcome.config;
  auto fail = [&](std::string message) {
    outcome.action = FlagsOutcome::Action::kError;
    outcome.error = std::move(message);
    return outcome;
  };

  // The environment first, so flags override it.
  for (const FlagSpec& flag : Flags()) {
    const std::string env = EnvName(flag.name);
    const char* value = getenv ? getenv(env.c_str()) : nullptr;
    if (value == nullptr || *value == '\0') continue;
    if (flag.value == nullptr) {
      const std::string v(value);
      if (v == "0" || v == "false") continue;
    }
    if (auto error = flag.set(config, value)) return fail(env + ": " + *error);
  }
  bool preload_from_flags = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      outcome.action = FlagsOutcome::Action::kHelp;
      return outcome;
    }
    if (arg == "--version") {
      outcome.action = FlagsOutcome::Action::kVersion;
      return outcome;
    }
    if (arg.rfind("--", 0) != 0) return fail("unexpected argument '" + arg + "' (see --help)");
    std::string name = arg.substr(2);
    std::optional<std::string> value;
    if (const std::size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    const FlagSpec* flag = FindFlag(name);
    if (flag == nullptr) return fail("unknown flag --" + name + " (see --help)");
    if (flag->value == nullptr) {
      if (value) return fail("--" + name + " takes no value");
      flag->set(config, "");
      continue;
    }
    if (!value) {
      if (i + 1 >= argc) return fail("--" + name + " needs a value: " + flag->value);
      value = argv[++i];
    }
    if (name == "preload" && !preload_from_flags) {
      config.preload.clear();  // Flags replace the environment's list.
      preload_from_flags = true;
    }
    if (auto error = flag->set(config, *value)) return fail("--" + name + ": " + *error);
  }
  // --no-preload leaves one empty marker; remove it (and anything before it is moot).
  const bool explicit_empty = !config.preload.empty() && config.preload.back().id.empty();
  if (explicit_empty) {
    config.preload.clear();
  } else if (config.preload.empty()) {
    PreloadSpec demo;
    demo.id = "demo";
    demo.scene_name = "two_level_ramp";
    config.preload.push_back(demo);
  }
  return outcome;
}

std::string UsageText() {
  std::string text =
      "Usage: strata-server [FLAGS]\n"
      "Serves Strata's gRPC API (strata.v1.MapService, strata.v1.PlannerService, health,\n"
      "reflection) and Prometheus metrics. Every flag can also be set by the environment\n"
      "variable in brackets; a flag overrides its variable.\n\n";
  for (const FlagSpec& flag : Flags()) {
    text += "  --";
    text += flag.name;
    if (flag.value != nullptr) {
      text += ' ';
      text += flag.value;
    }
    text += "  [" + EnvName(flag.name) + "]\n      ";
    text += flag.help;
    text += '\n';
  }
  text += "  --help, --version\n";
  return text;
}

}  // namespace strata::server
