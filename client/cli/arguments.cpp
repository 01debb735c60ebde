#include "arguments.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace strata::cli {

Arguments::Arguments(int argc, const char* const* argv,
                     const std::set<std::string>& boolean_flags) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0 || arg == "-") {
      positionals_.push_back(arg);
      continue;
    }
    if (arg == "--") throw UsageError("unexpected \"--\"");
    std::string name = arg.substr(2);
    const std::size_t equals = name.find('=');
    if (equals != std::string::npos) {
      flags_.emplace(name.substr(0, equals), name.substr(equals + 1));
    } else if (boolean_flags.count(name) > 0) {
      flags_.emplace(name, "true");
    } else {
      if (i + 1 >= argc) throw UsageError("--" + name + " needs a value");
      flags_.emplace(name, argv[++i]);
    }
  }
}

std::optional<std::string> Arguments::NextPositional() {
  if (positionals_.empty()) return std::nullopt;
  std::string value = positionals_.front();
  positionals_.erase(positionals_.begin());
  return value;
}

std::optional<std::string> Arguments::Take(const std::string& name) {
  auto [first, last] = flags_.equal_range(name);
  if (first == last) return std::nullopt;
  std::string value = std::prev(last)->second;
  flags_.erase(first, last);
  return value;
}

bool Arguments::TakeBool(const std::string& name) {
  const std::optional<std::string> value = Take(name);
  if (!value) return false;
  if (*value == "true" || *value == "1") return true;
  if (*value == "false" || *value == "0") return false;
  throw UsageError("--" + name + " takes no value (or true/false), got \"" + *value + "\"");
}

double ParseDouble(const std::string& text, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE ||
      !std::isfinite(value)) {
    throw UsageError(what + " must be a finite number, got \"" + text + "\"");
  }
  return value;
}

std::optional<double> Arguments::TakeDouble(const std::string& name) {
  const std::optional<std::string> value = Take(name);
  if (!value) return std::nullopt;
  return ParseDouble(*value, "--" + name);
}

std::optional<long long> Arguments::TakeInteger(const std::string& name, long long min,
                                                long long max) {
  const std::optional<std::string> value = Take(name);
  if (!value) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const long long parsed = std::strtoll(value->c_str(), &end, 10);
  if (value->empty() || end != value->c_str() + value->size() || errno == ERANGE || parsed < min ||
      parsed > max) {
    throw UsageError("--" + name + " must be an integer in [" + std::to_string(min) + ", " +
                     std::to_string(max) + "], got \"" + *value + "\"");
  }
  return parsed;
}

std::optional<std::array<double, 3>> Arguments::TakeVector3(const std::string& name) {
  const std::optional<std::string> value = Take(name);
  if (!value) return std::nullopt;
  std::array<double, 3> xyz{};
  std::size_t begin = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = value->find(',', begin);
    const bool last = i == 2;
    if (last != (comma == std::string::npos)) {
      throw UsageError("--" + name + " must be x,y,z (three numbers in metres), got \"" + *value +
                       "\"");
    }
    const std::string part = value->substr(begin, last ? std::string::npos : comma - begin);
    xyz[i] = ParseDouble(part, "--" + name + " component " + "xyz"[i]);
    begin = comma + 1;
  }
  return xyz;
}

void Arguments::Finish() const {
  if (!flags_.empty()) throw UsageError("unknown or misplaced flag --" + flags_.begin()->first);
  if (!positionals_.empty())
    throw UsageError("unexpected argument \"" + positionals_.front() + "\"");
}

}  // namespace strata::cli
