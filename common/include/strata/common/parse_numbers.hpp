#pragma once
/// Numbers and points as people type them on a command line ("2.5", "2,2,0.3"): one reading
/// for every program, so that "nan" or "1e999" is refused the same everywhere.
#include <array>
#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

namespace strata::common {

/// `text` as a finite decimal number spanning all of it; nothing for anything else ("", "1x",
/// "nan", "inf", "1e999").
inline std::optional<double> ParseFinite(std::string_view text) {
  double value = 0;
  const char* end = text.data() + text.size();
  const auto [used, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || used != end || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

/// "x,y,z" as three finite numbers; nothing, with the problem in *error, otherwise.
inline std::optional<std::array<double, 3>> ParseXyz(std::string_view text, std::string* error) {
  std::array<double, 3> xyz{};
  std::size_t begin = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', begin);
    const bool last = i == 2;
    if (last != (comma == std::string_view::npos)) {
      *error = "must be x,y,z (three numbers in metres), got \"" + std::string(text) + "\"";
      return std::nullopt;
    }
    const std::string_view part = text.substr(begin, last ? std::string_view::npos : comma - begin);
    const std::optional<double> value = ParseFinite(part);
    if (!value) {
      *error = std::string("component ") + "xyz"[i] + " must be a finite number, got \"" +
               std::string(part) + "\"";
      return std::nullopt;
    }
    xyz[i] = *value;
    begin = comma + 1;
  }
  return xyz;
}

}  // namespace strata::common
