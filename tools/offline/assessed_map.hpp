#pragma once
// A MAP argument of the offline tools, loaded and assessed: a point-cloud file (PCD, PLY, .bt,
// .ot), a built-in scene written as "scene:NAME" or "scene:NAME:SEED"
// (strata/scenes/map_source.hpp), or a saved model (strata/io/saved_model.hpp), loaded as saved.

#include <cstddef>
#include <memory>
#include <string>

#include "strata/assessment/terrain_model.hpp"

namespace strata::offline {

/// A MAP argument loaded and assessed.
struct AssessedMap {
  std::shared_ptr<const TerrainModel> model;
  std::size_t raw_point_count = 0;    ///< Points in the file, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped for a NaN/Inf coordinate.
  double load_s = 0;                  ///< Reading the file or generating the scene [s].
  bool from_saved_model = false;      ///< Loaded from a saved model: not assessed now.
};

/// ParseMapSource and LoadMapSource (strata/scenes/map_source.hpp), then TerrainModel::Assess
/// with `config` and `control`; fails as either does. A saved model is loaded instead
/// (LoadModel), and `config` must then either ask for nothing (AssessmentConfig's defaults)
/// or assess alike (FirstDifference): kInvalidInput naming the first field that differs.
Expected<AssessedMap> LoadAndAssess(const std::string& source, const AssessmentConfig& config,
                                    const AssessmentControl& control = {});

/// Follows an assessment on stderr: a line that updates in place on a terminal, else a line
/// per quarter of each stage ("strata-offline: ground_filter 50%"); nothing when `enabled` is
/// false.
AssessmentControl ProgressLine(bool enabled);

}  // namespace strata::offline
