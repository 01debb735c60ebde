// README.md's table of assessment parameters against the code: every field of
// AssessmentConfig (ForEachField, the one list) has a row, and the row's default is the
// struct's, so the documentation cannot drift from the code.
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "strata/assessment/terrain_config.hpp"

namespace strata {
namespace {

// field -> default text, from the rows "| `field` | default | meaning |" of the section.
std::map<std::string, std::string> ReadmeTable(const std::string& section) {
  std::ifstream readme(std::string(STRATA_SOURCE_DIR) + "/README.md");
  EXPECT_TRUE(readme.good());
  std::map<std::string, std::string> rows;
  bool inside = false;
  for (std::string line; std::getline(readme, line);) {
    if (line.rfind("#", 0) == 0) inside = line.find(section) != std::string::npos;
    if (!inside || line.rfind("| `", 0) != 0) continue;
    const std::size_t name_end = line.find("` |");
    const std::size_t value_end = line.find(" |", name_end + 3);
    rows[line.substr(3, name_end - 3)] = line.substr(name_end + 4, value_end - name_end - 4);
  }
  return rows;
}

// The number a cell means: "20°" in radians, "1e8", "0.2", "false".
double Value(const std::string& text) {
  if (text == "false") return 0;
  if (text == "true") return 1;
  const std::size_t degrees = text.find("°");
  if (degrees != std::string::npos)
    return std::stod(text.substr(0, degrees)) * std::numbers::pi / 180;
  return std::stod(text);
}

TEST(ReadmeDefaults, TheAssessmentParameterTableMatchesTheCode) {
  const std::map<std::string, std::string> rows = ReadmeTable("Assessment parameters");
  ASSERT_FALSE(rows.empty());
  int checked = 0;
  const AssessmentConfig defaults;
  ForEachField(defaults, [&](const char* name, const auto& value) {
    const auto row = rows.find(name);
    ASSERT_NE(row, rows.end()) << name << " has no row in README.md's Assessment parameters";
    const double documented = Value(row->second);
    const double code = static_cast<double>(value);
    EXPECT_NEAR(documented, code, 1e-3 * std::max(1.0, std::abs(code)))
        << name << ": README.md says " << row->second << ", the code " << code;
    ++checked;
  });
  EXPECT_EQ(checked, static_cast<int>(rows.size())) << "README.md documents a field the code lacks";
}

}  // namespace
}  // namespace strata
