#include "offline/scene_command.hpp"

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <optional>

#include "offline/assessment_options.hpp"
#include "strata/cloud_io.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata::offline {
namespace {

struct SceneArgs {
  std::string name;
  std::uint32_t seed = kDefaultSceneSeed;
  std::optional<double> spacing_m;  // The scene's default when absent.
  std::string out;
};

// Returns an error message, or nothing when the arguments parsed.
std::optional<std::string> ParseArgs(const std::vector<std::string>& args, SceneArgs* out) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--seed" || a == "--spacing" || a == "--out") {
      if (i + 1 >= args.size()) return a + " needs a value";
      const std::string& text = args[++i];
      if (a == "--out") {
        out->out = text;
      } else if (a == "--seed") {
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out->seed);
        if (ec != std::errc() || end != text.data() + text.size()) {
          return "--seed needs an unsigned 32-bit integer, got '" + text + "'";
        }
      } else {
        out->spacing_m = ParseNumber(text);
        if (!out->spacing_m) return "--spacing needs a number [m], got '" + text + "'";
      }
      continue;
    }
    if (a.starts_with("--")) return "unknown option " + a;
    if (!out->name.empty()) return "more than one NAME given ('" + out->name + "', '" + a + "')";
    out->name = a;
  }
  if (out->name.empty()) return "NAME is missing";
  if (out->out.empty()) return "--out FILE is missing";
  return std::nullopt;
}

}  // namespace

int RunScene(const std::vector<std::string>& args) {
  SceneArgs parsed;
  if (const auto problem = ParseArgs(args, &parsed)) {
    std::fprintf(stderr, "strata-offline scene: %s\n", problem->c_str());
    return 2;
  }
  if (!parsed.spacing_m) {
    const Expected<double> spacing = DefaultSceneSpacing(parsed.name);
    if (!spacing) {
      std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(spacing.error().code),
                   spacing.error().message.c_str());
      return 1;
    }
    parsed.spacing_m = *spacing;
  }
  const Expected<PointCloud> cloud = GenerateScene(parsed.name, parsed.seed, *parsed.spacing_m);
  if (!cloud) {
    std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(cloud.error().code),
                 cloud.error().message.c_str());
    return 1;
  }
  if (const Status written = SavePcd(*cloud, parsed.out); !written) {
    std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(written.error().code),
                 written.error().message.c_str());
    return 1;
  }
  std::printf("scene %s, seed %u, spacing %.3f m: %zu points written to %s\n", parsed.name.c_str(),
              parsed.seed, *parsed.spacing_m, cloud->size(), parsed.out.c_str());
  return 0;
}

}  // namespace strata::offline
