#pragma once
// A map that takes seconds to assess, for tests that watch an assessment under way or stop it.
#include <utility>

#include "maps/map_registry.hpp"

namespace strata::server::testing {

/// A 500 m x 500 m floor sampled every 0.2 m (6.25 million points): several seconds to assess
/// on one thread, so that progress can be watched and a deletion seen to stop it.
inline UploadMapSource LargeFloorSource() {
  constexpr int kSide = 2500;
  PointCloud cloud;
  cloud.reserve(kSide * kSide);
  for (int i = 0; i < kSide; ++i) {
    for (int j = 0; j < kSide; ++j) cloud.emplace_back(0.2f * i, 0.2f * j, 0.0f);
  }
  return UploadMapSource{std::move(cloud), 0};
}

}  // namespace strata::server::testing
