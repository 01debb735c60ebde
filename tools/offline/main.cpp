// strata-offline: the planner's command-line front end for work without a server.

#include <cstdio>
#include <exception>
#include <functional>

#include <CLI/CLI.hpp>

#include "offline/assess_command.hpp"
#include "offline/command_line.hpp"
#include "offline/plan_command.hpp"
#include "offline/scene_command.hpp"

int main(int argc, char** argv) {
  using namespace strata::offline;
  // The planner reports failures as values; what still throws (out of memory, a bug) ends
  // the run with a message and exit code 1 rather than an abort.
  try {
    CLI::App app(
        "strata-offline: terrain assessment and planning from the command line, without a "
        "server (README.md).",
        "strata-offline");
    app.footer(
        "`strata-offline COMMAND --help` shows a command's options.\n"
        "Exit codes: 0 success; 1 the map could not be loaded or assessed, the plan failed or "
        "an output could not be written; 2 bad arguments.\n");
    app.set_help_flag("-h,--help", "print this help and exit");
    app.set_help_all_flag("--help-all", "print the help of every command and exit");
    app.require_subcommand(1);

    std::function<int()> run;
    AddAssessCommand(app, &run);
    AddPlanCommand(app, &run);
    AddSceneCommand(app, &run);
    if (const std::optional<int> exit_code = ParseCommandLine(app, argc, argv)) return *exit_code;
    return run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "strata-offline: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "strata-offline: an unknown exception ended the run\n");
  }
  return kExitFailed;
}
