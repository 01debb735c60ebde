#pragma once
// Comparing assessed models byte for byte, for tests that make one model two ways.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "strata/io/saved_model.hpp"

namespace strata::test_util {

/// The saved model with the summary's timings zeroed: everything a plan reads, and the counts.
inline std::string BytesWithoutTimings(const TerrainModel& model) {
  AssessmentSummary summary = model.summary();
  summary.timings = {};
  auto copy = TerrainModel::FromParts(model.config(), summary, model.surfaces(), model.fields());
  EXPECT_TRUE(copy.ok());
  return copy.ok() ? SerializeModel(**copy) : std::string();
}

/// The first byte where two saved models differ (the shorter length when one is a prefix),
/// for a readable failure.
inline std::size_t FirstDifferingByte(const std::string& a, const std::string& b) {
  return static_cast<std::size_t>(
      std::mismatch(a.begin(), a.begin() + std::min(a.size(), b.size()), b.begin()).first -
      a.begin());
}

}  // namespace strata::test_util
