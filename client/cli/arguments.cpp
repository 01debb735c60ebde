#include "arguments.hpp"

#include "strata/common/parse_numbers.hpp"

#include <string_view>

namespace strata::cli {

using common::ParseFinite;

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
  return common::ParseXyz(text, error);
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
