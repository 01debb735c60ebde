#include "offline/assessment_options.hpp"

#include <numbers>

namespace strata::offline {

std::optional<double> ParseNumber(const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

bool IsAssessmentOption(const std::string& arg) {
  return arg == "--resolution" || arg == "--radius" || arg == "--max-tilt-deg" ||
         arg == "--threads";
}

std::optional<std::string> TakeAssessmentOption(const std::vector<std::string>& args,
                                                std::size_t* i, AssessmentConfig* config) {
  const std::string& name = args[*i];
  if (*i + 1 >= args.size()) return name + " needs a value";
  const std::string& text = args[++*i];
  const std::optional<double> v = ParseNumber(text);
  if (!v) return name + " needs a number, got '" + text + "'";
  if (name == "--resolution") config->grid.resolution_m = *v;
  if (name == "--radius") config->ground.radius_m = *v;
  if (name == "--max-tilt-deg") config->ground.max_tilt_rad = *v * std::numbers::pi / 180;
  if (name == "--threads") config->num_threads = static_cast<int>(*v);
  return std::nullopt;
}

}  // namespace strata::offline
