// strata: the command-line client of strata-server. See client/README.md.
#include <exception>
#include <iostream>

#include "commands.hpp"

namespace strata::cli {
namespace {

int Run(int argc, const char* const* argv) {
  Context ctx;
  Command run;
  CLI::App app("", "strata");
  AddStrataCommands(app, &ctx, &run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::cout << app.help("", CLI::AppFormatMode::All);
    return kExitOk;
  } catch (const CLI::ParseError& error) {
    throw UsageError(error.what());
  }
  if (!run) {
    // No command, or `maps` without one: name what the last command given offers.
    const CLI::App* given = &app;
    while (!given->get_subcommands().empty()) given = given->get_subcommands().front();
    std::string commands;
    for (const CLI::App* command : given->get_subcommands({})) {
      commands += (commands.empty() ? "" : ", ") + command->get_name();
    }
    throw UsageError("no command given; " + given->get_display_name(true) +
                     " takes one of: " + commands);
  }
  return run();
}

}  // namespace
}  // namespace strata::cli

int main(int argc, char** argv) {
  try {
    return strata::cli::Run(argc, argv);
  } catch (const strata::cli::UsageError& error) {
    std::cerr << "strata: " << error.what() << "\n(strata --help shows the usage)\n";
    return strata::cli::kExitUsage;
  } catch (const std::exception& error) {
    std::cerr << "strata: " << error.what() << "\n";
    return strata::cli::kExitUsage;
  }
}
