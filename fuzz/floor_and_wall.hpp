#pragma once
// The model the saved-model seed and the saved-graph target share: a 2 m x 2 m floor with a
// low wall across it, a few kilobytes, so that a target runs thousands of inputs a second.
#include <memory>

#include "strata/assessment/terrain_model.hpp"
#include "strata/point_cloud.hpp"

namespace strata::fuzz {

inline std::shared_ptr<const TerrainModel> FloorAndWallModel() {
  PointCloud cloud;
  for (int i = 0; i < 40; ++i) {
    for (int j = 0; j < 40; ++j) cloud.emplace_back(0.05f * i, 0.05f * j, 0.0f);
    for (int k = 1; k < 10; ++k) cloud.emplace_back(1.0f, 0.05f * i, 0.05f * k);
  }
  AssessmentConfig config;
  config.grid.resolution_m = 0.25;
  return TerrainModel::Assess(cloud, config).value();
}

}  // namespace strata::fuzz
