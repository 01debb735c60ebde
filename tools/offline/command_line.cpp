#include "offline/command_line.hpp"

#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>

#include "strata/planning/robot_profile.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::offline {

std::string DefaultText(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

void AddProgressFlag(CLI::App& command, bool* progress) {
  *progress = isatty(STDERR_FILENO) != 0;
  command.add_flag("--progress,!--no-progress", *progress,
                   "show the assessment's stage and fraction done on stderr (default: when "
                   "stderr is a terminal)");
}

std::optional<int> ParseCommandLine(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);  // The help of the command given, on stdout; exit code 0.
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
  } catch (const CLI::ParseError& error) {
    // Name the command the problem belongs to, as the commands' own failures do.
    std::string who = app.get_name();
    std::string help = who + " --help";
    for (const CLI::App* command : app.get_subcommands()) {
      who += " " + command->get_name();
      help = app.get_name() + " " + command->get_name() + " --help";
    }
    std::fprintf(stderr, "%s: %s\nRun '%s' for the options.\n", who.c_str(), error.what(),
                 help.c_str());
    return kExitBadArguments;
  }
}

void AddAssessmentOptions(CLI::App& command, AssessmentConfig* config) {
  // --help shows the values *config holds now: AssessmentConfig's defaults.
  command.add_option("--resolution", config->grid.resolution_m, "grid cell edge [m]")
      ->type_name("M")
      ->capture_default_str();
  command.add_option("--radius", config->ground.radius_m, "Valid Ground Filter radius [m]")
      ->type_name("M")
      ->capture_default_str();
  command
      .add_option_function<double>(
          "--max-tilt-deg",
          [config](double degrees) {
            config->ground.max_tilt_rad = degrees * std::numbers::pi / 180;
          },
          "steepest ground the Valid Ground Filter keeps [deg]")
      ->type_name("D")
      ->default_str(DefaultText(config->ground.max_tilt_rad * 180 / std::numbers::pi));
  command
      .add_option("--threads", config->num_threads,
                  "threads of the assessment's parallel stages; 0: every core")
      ->type_name("N")
      ->capture_default_str();
}

CLI::Validator AtLeast(double min) {
  return CLI::Validator(
      [min](const std::string& text) -> std::string {
        double value = 0;
        if (CLI::detail::lexical_cast(text, value) && value >= min) return {};
        return "must be a number >= " + DefaultText(min) + ", got '" + text + "'";
      },
      "");  // Only the placeholder in --help.
}

std::string MapHelp() {
  return fmt::format(
      "a .pcd, .ply, .bt or .ot file, or a built-in scene "
      "scene:NAME[:SEED][:size_m=M][:spacing_m=M] (NAME as for the scene command; SEED default "
      "{}; size and spacing default: the scene's own)",
      kDefaultSceneSeed);
}

CLI::Validator BuiltinRobotName() {
  return CLI::Validator(
      [](const std::string& name) -> std::string {
        const Expected<RobotProfile> profile = BuiltinProfile(name);
        return profile ? std::string() : profile.error().message;
      },
      "");  // The option's description lists the names.
}

std::string BuiltinRobotNames() {
  std::string names;
  for (const std::string& name : BuiltinProfileNames()) names += (names.empty() ? "" : ", ") + name;
  return names;
}

}  // namespace strata::offline
