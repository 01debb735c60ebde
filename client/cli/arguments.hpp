#pragma once
// The strata CLI's command line on CLI11: subcommands that run after parsing, and the checks
// of the values the commands share (finite numbers, x,y,z). A bad command line is a
// CLI::ParseError, which main turns into a message and exit code 2.
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>

namespace strata::cli {

/// What parsing selected: runs the command and returns the exit code.
using Command = std::function<int()>;

/// Adds subcommand `name` to `parent`. Its options write into the returned Flags; when the
/// command line selects it, parsing sets *run to `body(flags)` (run after parsing, so
/// that a command never starts on a half-checked command line).
template <typename Flags>
std::pair<CLI::App*, std::shared_ptr<Flags>> AddCommand(CLI::App& parent, const std::string& name,
                                                        const std::string& help, Command* run,
                                                        std::function<int(const Flags&)> body) {
  auto flags = std::make_shared<Flags>();
  CLI::App* command = parent.add_subcommand(name, help);
  command->callback(
      [flags, run, body = std::move(body)] { *run = [flags, body] { return body(*flags); }; });
  return {command, flags};
}

/// Checks: a finite number (CLI11's own number checks let inf and nan through), and one > 0.
CLI::Validator FiniteNumber();
CLI::Validator PositiveNumber();

/// Adds `--name x,y,z` (three finite numbers, in metres) writing into *xyz.
CLI::Option* AddVector3(CLI::App& command, const std::string& name, const std::string& help,
                        std::optional<std::array<double, 3>>* xyz);

/// "x,y,z" as three finite numbers; nullopt with the problem in *error otherwise.
std::optional<std::array<double, 3>> ParseVector3(const std::string& text, std::string* error);

/// A route's via-point on the command line (PlanRequest.via).
struct ViaPoint {
  std::array<double, 3> position_m{};
  bool stop = false;
};
/// "x,y,z" (flow through) or "x,y,z:stop" (come to rest there); nullopt with the problem in
/// *error otherwise.
std::optional<ViaPoint> ParseVia(const std::string& text, std::string* error);

}  // namespace strata::cli
