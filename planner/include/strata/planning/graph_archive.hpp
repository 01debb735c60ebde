#pragma once
/// Where a PlanningMap finds the surface graphs built on its model before (by another replica,
/// or before a restart) and keeps those it builds: a kilometre's graph takes seconds to build
/// and a fraction of that to load (strata/io/saved_graph.hpp). The planner defines the
/// interface only; a server keeps graphs in its map store.

#include <memory>
#include <optional>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata {

/// Thread-safe: one archive serves every plan on its map.
class GraphArchive {
 public:
  virtual ~GraphArchive() = default;
  /// The graph of `params` on `model`, when one was kept; nullopt to build it (none kept, or
  /// the kept one does not load: the archive says why where it logs).
  virtual std::optional<SurfaceGraph> Find(const TerrainModel& model,
                                           const TraversabilityParams& params) const = 0;
  /// Whether a graph of `params` is kept, without loading it: a graph patched from another
  /// version's is made faster than it loads, and is kept only where none is.
  virtual bool Holds(const TraversabilityParams& params) const = 0;
  /// Keeps `graph`, just built on `model`; may return before it is kept (holding both).
  virtual void Keep(std::shared_ptr<const TerrainModel> model,
                    std::shared_ptr<const SurfaceGraph> graph) const = 0;
};

}  // namespace strata
