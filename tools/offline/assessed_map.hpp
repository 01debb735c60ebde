#pragma once
// A MAP argument of the offline tools loaded and assessed: a file path (PCD, PLY, .bt, .ot) or a
// built-in scene written as "scene:NAME" or "scene:NAME:SEED" (strata/scenes/map_source.hpp).

#include <cstddef>
#include <memory>
#include <string>

#include "strata/terrain_model.hpp"

namespace strata::offline {

/// A MAP argument loaded and assessed.
struct AssessedMap {
  std::shared_ptr<const TerrainModel> model;
  std::size_t raw_point_count = 0;    ///< Points in the file, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped for a NaN/Inf coordinate.
  double load_s = 0;                  ///< Reading the file or generating the scene [s].
};

/// ParseMapSource and LoadMapSource (strata/scenes/map_source.hpp), then TerrainModel::Assess with
/// `config`; fails as either does.
Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config);

}  // namespace strata::offline
