// strata-offline: the planner's command-line front end for work without a server.

#include <cstdio>
#include <string>
#include <vector>

#include "offline/assess_command.hpp"
#include "offline/plan_command.hpp"
#include "offline/scene_command.hpp"

namespace {

constexpr const char* kUsage =
    "usage: strata-offline COMMAND [ARGS]\n"
    "\n"
    "commands:\n"
    "  assess MAP [--resolution M] [--radius M] [--max-tilt-deg D] [--threads N] [--json]\n"
    "      Terrain assessment of MAP: a .pcd/.ply/.bt/.ot file or a built-in scene\n"
    "      (scene:NAME or scene:NAME:SEED; NAME as for the scene command). Prints point\n"
    "      counts, grid, memory and seconds per stage.\n"
    "  scene NAME [--seed S] [--spacing M] --out FILE.pcd\n"
    "      Writes a built-in scene as a binary PCD: stairs_ramp_room, two_level_ramp,\n"
    "      uneven_terrain, uneven_forest, abandoned_station, parking_garage,\n"
    "      crossing_viaducts or indoor_tables (docs/scenes.md), seed S (default 1),\n"
    "      lattice spacing M [m] (default: the scene's own).\n"
    "  plan MAP --start X,Y,Z --goal X,Y,Z [--robot NAME] [--time-budget S] [--json]\n"
    "       [--svg FILE] [--resolution M] [--radius M] [--max-tilt-deg D] [--threads N]\n"
    "      Assesses MAP as assess does, then plans a trajectory from start to goal [m] for\n"
    "      a built-in robot (differential, the default, or biped) within S seconds\n"
    "      (default 2). Prints where start and goal snapped, the plan's figures and its\n"
    "      pieces; --svg also draws the plan (top view and side view) into FILE.\n";

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help") {
    std::fputs(kUsage, args.empty() ? stderr : stdout);
    return args.empty() ? 2 : 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  if (args[0] == "assess") return strata::offline::RunAssess(rest);
  if (args[0] == "plan") return strata::offline::RunPlan(rest);
  if (args[0] == "scene") return strata::offline::RunScene(rest);
  std::fprintf(stderr, "strata-offline: unknown command '%s'\n\n%s", args[0].c_str(), kUsage);
  return 2;
}
