#pragma once
// What strata-offline and strata-bench share on the command line (CLI11): how a parsed line
// ends (help, a bad line, or a command to run), the assessment options of every command that
// assesses a map, and the checks of a few value types.

#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "strata/assessment/terrain_config.hpp"

namespace strata::offline {

/// Exit codes of the offline tools.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;  ///< The map could not be loaded or assessed, ...
inline constexpr int kExitBadArguments = 2;

/// Parses argv into `app`. Returns kExitOk after printing the help asked for (stdout), or
/// kExitBadArguments after printing "PROGRAM[ COMMAND]: problem" and a pointer to --help
/// (stderr); nothing when the line parsed and the caller runs it.
std::optional<int> ParseCommandLine(CLI::App& app, int argc, const char* const* argv);

/// Adds --resolution, --radius, --max-tilt-deg and --threads, which write into *config; --help
/// shows the values *config holds when they are added (AssessmentConfig's defaults). Range
/// checks are left to AssessmentConfig::Validate, which names the field (exit code 1), as for
/// every other way a configuration reaches the planner.
void AddAssessmentOptions(CLI::App& command, AssessmentConfig* config);

/// Adds --progress: the assessment's stage and fraction done on stderr (ProgressLine); on by
/// default when stderr is a terminal.
void AddProgressFlag(CLI::App& command, bool* progress);

/// `value` as --help shows a default, e.g. 0.2 or 20 (a struct's default, so --help cannot
/// drift from the code).
std::string DefaultText(double value);

/// A number >= `min`; the message names the bound and the value.
CLI::Validator AtLeast(double min);

/// --help of a MAP argument: a point-cloud file or scene:NAME[:SEED][:size_m=M][:spacing_m=M]
/// (ParseMapSource).
std::string MapHelp();

/// A built-in robot profile's name (BuiltinProfile); the message names the known ones.
CLI::Validator BuiltinRobotName();
/// The built-in profiles' names, "differential, biped", for --help.
std::string BuiltinRobotNames();

}  // namespace strata::offline
