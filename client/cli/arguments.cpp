#include "arguments.hpp"

#include <charconv>
#include <cmath>
#include <string_view>

namespace strata::cli {
namespace {

std::optional<double> ParseFinite(const std::string& text) {
  double value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace

CLI::Validator FiniteNumber() {
  return CLI::Validator(
      [](std::string& text) {
        return ParseFinite(text) ? std::string() : "must be a finite number, got \"" + text + "\"";
      },
      "");
}

CLI::Validator PositiveNumber() {
  return CLI::Validator(
      [](std::string& text) {
        const auto value = ParseFinite(text);
        return value && *value > 0 ? std::string() : "must be a number > 0, got \"" + text + "\"";
      },
      "");
}

std::optional<std::array<double, 3>> ParseVector3(const std::string& text, std::string* error) {
  std::array<double, 3> xyz{};
  std::size_t begin = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', begin);
    const bool last = i == 2;
    if (last != (comma == std::string::npos)) {
      *error = "must be x,y,z (three numbers in metres), got \"" + text + "\"";
      return std::nullopt;
    }
    const std::string part = text.substr(begin, last ? std::string::npos : comma - begin);
    const auto value = ParseFinite(part);
    if (!value) {
      *error =
          std::string("component ") + "xyz"[i] + " must be a finite number, got \"" + part + "\"";
      return std::nullopt;
    }
    xyz[i] = *value;
    begin = comma + 1;
  }
  return xyz;
}

std::optional<ViaPoint> ParseVia(const std::string& text, std::string* error) {
  constexpr std::string_view kStop = ":stop";
  const bool stop = text.ends_with(kStop);
  const std::optional<std::array<double, 3>> xyz =
      ParseVector3(stop ? text.substr(0, text.size() - kStop.size()) : text, error);
  if (!xyz) {
    *error += " (a via is x,y,z, or x,y,z:stop to come to rest there)";
    return std::nullopt;
  }
  return ViaPoint{*xyz, stop};
}

CLI::Option* AddVector3(CLI::App& command, const std::string& name, const std::string& help,
                        std::optional<std::array<double, 3>>* xyz) {
  return command
      .add_option_function<std::string>(
          name,
          [xyz](const std::string& text) {
            std::string error;
            *xyz = ParseVector3(text, &error);  // Checked below before this runs.
          },
          help)
      ->type_name("x,y,z")
      ->check(CLI::Validator(
          [](std::string& text) {
            std::string error;
            return ParseVector3(text, &error) ? std::string() : error;
          },
          ""));
}

}  // namespace strata::cli
