#pragma once
// Resolves a MAP argument of the offline tools: a file path (PCD, PLY, .bt, .ot) or a built-in
// scene written as "scene:NAME" or "scene:NAME:SEED".

#include <cstddef>
#include <memory>
#include <string>

#include "strata/cloud_io.hpp"
#include "strata/terrain_model.hpp"

namespace strata::offline {

/// Loads a file or generates a scene; the result is sanitised either way.
Expected<LoadedCloud> LoadMapSource(const std::string& source);

/// A MAP argument loaded and assessed.
struct AssessedMap {
  std::shared_ptr<const TerrainModel> model;
  std::size_t raw_point_count = 0;    ///< Points in the file, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped for a NaN/Inf coordinate.
  double load_s = 0;                  ///< Reading the file or generating the scene [s].
};

/// LoadMapSource, then TerrainModel::Assess with `config`; fails as either does.
Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config);

}  // namespace strata::offline
