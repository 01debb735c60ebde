#include "offline/scene_command.hpp"

#include <cstdint>
#include <cstdio>
#include <memory>

#include "offline/command_line.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata::offline {
namespace {

struct SceneArgs {
  std::string name;
  std::uint32_t seed = kDefaultSceneSeed;
  SceneOptions options;  // The scene's defaults where unset.
  std::string out;
};

std::string SceneNameList() {
  std::string names;
  for (const std::string& name : SceneNames()) names += (names.empty() ? "" : ", ") + name;
  return names;
}

int Fail(const Error& error) {
  std::fprintf(stderr, "strata-offline scene: %s: %s\n", ErrorCodeName(error.code),
               error.message.c_str());
  return kExitFailed;
}

int RunScene(const SceneArgs& parsed) {
  const Expected<SceneOptions> options = ResolveSceneOptions(parsed.name, parsed.options);
  if (!options) return Fail(options.error());
  const Expected<PointCloud> cloud = GenerateScene(parsed.name, parsed.seed, *options);
  if (!cloud) return Fail(cloud.error());
  if (const Status written = SavePcd(*cloud, parsed.out); !written) return Fail(written.error());
  std::printf("scene %s, seed %u", parsed.name.c_str(), parsed.seed);
  if (options->size_m) std::printf(", size %g m", *options->size_m);
  std::printf(", spacing %.3f m: %zu points written to %s\n", *options->spacing_m, cloud->size(),
              parsed.out.c_str());
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
  command
      ->add_option(
          "--size", args->options.size_m,
          "side of a scene with a size parameter (outdoor_site: 40 to 1000, default 100) [m]")
      ->type_name("M");
  command
      ->add_option("--spacing", args->options.spacing_m,
                   "lattice spacing [m]; default: the scene's own")
      ->type_name("M");
  command->add_option("--out", args->out, "the PCD file to write")->type_name("FILE")->required();
  command->callback([args, run] { *run = [args] { return RunScene(*args); }; });
}

}  // namespace strata::offline
