#pragma once
// Command-line options shared by the offline commands that assess a map (assess, plan), so
// both spell and interpret them the same way.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "strata/terrain_config.hpp"

namespace strata::offline {

/// A decimal number spanning all of `text`, or nothing.
std::optional<double> ParseNumber(const std::string& text);

/// Whether `arg` names an assessment option: --resolution, --radius, --max-tilt-deg, --threads.
bool IsAssessmentOption(const std::string& arg);

/// Reads the assessment option args[*i] and its value into *config and advances *i to the
/// value. Returns an error message when the value is missing or not a number. Range checks
/// are left to AssessmentConfig::Validate, which names the field. Precondition:
/// IsAssessmentOption(args[*i]).
std::optional<std::string> TakeAssessmentOption(const std::vector<std::string>& args,
                                                std::size_t* i, AssessmentConfig* config);

}  // namespace strata::offline
