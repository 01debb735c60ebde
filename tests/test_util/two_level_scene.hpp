#pragma once
// The two-level scene (strata/scenes.hpp, seed 5) assessed at 0.2 m, built once per test
// binary: a ramp (sloped ground), a deck (a ceiling over the floor) and pillars (obstacles), so
// every cost term and terrain query has something to bite on.
#include <memory>

#include "strata/assessment/terrain_model.hpp"
#include "strata/scenes/basic_scenes.hpp"

namespace strata::test_util {

inline const TerrainModel& TwoLevelScene() {
  static const std::shared_ptr<const TerrainModel> model = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.2;
    return TerrainModel::Assess(GenerateTwoLevelRamp(5), config).value();
  }();
  return *model;
}

}  // namespace strata::test_util
