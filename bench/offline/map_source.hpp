#pragma once
// Resolves a MAP argument of the offline tools: a file path (PCD, PLY, .bt, .ot) or a built-in
// scene written as "scene:NAME" or "scene:NAME:SEED".

#include <string>

#include "strata/cloud_io.hpp"

namespace strata::offline {

/// Loads a file or generates a scene; the result is sanitised either way.
Expected<LoadedCloud> LoadMapSource(const std::string& source);

}  // namespace strata::offline
