#pragma once
// Command-line parsing for the strata CLI: positionals and --flags (as "--name value" or
// "--name=value", anywhere on the line). Bad arguments throw UsageError, which main turns
// into a message and exit code 2.
#include <array>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace strata::cli {

/// A bad command line: main prints it with a hint and exits with code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parsed argv. Each command takes the flags it knows; Finish() rejects what is left.
class Arguments {
 public:
  /// Parses argv[1..]; `boolean_flags` take no value. Throws UsageError on "--" alone or a
  /// value flag at the end of the line.
  Arguments(int argc, const char* const* argv, const std::set<std::string>& boolean_flags);

  /// Removes and returns the next positional; nullopt when there are none left.
  std::optional<std::string> NextPositional();
  /// Removes and returns the flag's value (the last one when repeated).
  std::optional<std::string> Take(const std::string& name);
  /// Removes a boolean flag; true when it was given.
  bool TakeBool(const std::string& name);
  /// Take() parsed as a finite number; throws UsageError naming the flag otherwise.
  std::optional<double> TakeDouble(const std::string& name);
  /// Take() parsed as an integer in [min, max].
  std::optional<long long> TakeInteger(const std::string& name, long long min, long long max);
  /// Take() parsed as "x,y,z" (three finite numbers).
  std::optional<std::array<double, 3>> TakeVector3(const std::string& name);

  /// Throws UsageError naming the first unused flag or positional.
  void Finish() const;

 private:
  std::vector<std::string> positionals_;
  std::multimap<std::string, std::string> flags_;
};

/// Parses a finite double; throws UsageError naming `what`.
double ParseDouble(const std::string& text, const std::string& what);

}  // namespace strata::cli
