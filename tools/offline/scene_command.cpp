#include "offline/scene_command.hpp"

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>

#include "offline/command_line.hpp"
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

std::string SceneNameList() {
  std::string names;
  for (const std::string& name : SceneNames()) names += (names.empty() ? "" : ", ") + name;
  return names;
}

int RunScene(SceneArgs parsed) {
  if (!parsed.spacing_m) {
    const Expected<double> spacing = DefaultSceneSpacing(parsed.name);
    if (!spacing) {
      std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(spacing.error().code),
                   spacing.error().message.c_str());
      return kExitFailed;
    }
    parsed.spacing_m = *spacing;
  }
  const Expected<PointCloud> cloud = GenerateScene(parsed.name, parsed.seed, *parsed.spacing_m);
  if (!cloud) {
    std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(cloud.error().code),
                 cloud.error().message.c_str());
    return kExitFailed;
  }
  if (const Status written = SavePcd(*cloud, parsed.out); !written) {
    std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(written.error().code),
                 written.error().message.c_str());
    return kExitFailed;
  }
  std::printf("scene %s, seed %u, spacing %.3f m: %zu points written to %s\n", parsed.name.c_str(),
              parsed.seed, *parsed.spacing_m, cloud->size(), parsed.out.c_str());
  return kExitOk;
}

}  // namespace

void AddSceneCommand(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<SceneArgs>();
  CLI::App* command =
      app.add_subcommand("scene", "Writes a built-in scene as a binary PCD (x, y, z as float32).");
  command->add_option("NAME", args->name, "one of " + SceneNameList() + " (docs/scenes.md)")
      ->type_name("")
      ->required();
  command->add_option("--seed", args->seed, "seed of the jitter (and of some layouts)")
      ->type_name("S")
      ->capture_default_str();
  command->add_option("--spacing", args->spacing_m, "lattice spacing [m]; default: the scene's own")
      ->type_name("M");
  command->add_option("--out", args->out, "the PCD file to write")->type_name("FILE")->required();
  command->callback([args, run] { *run = [args] { return RunScene(*args); }; });
}

}  // namespace strata::offline
