#pragma once
/// Robots' surface graphs kept in the map store beside the terrain they were built on
/// (MapStore::PutGraph), so that a replica that plans on a map loads a graph another replica
/// built instead of building it again (a kilometre's graph: seconds to build, a fraction of
/// that to load). Graphs are written by a GraphWriter: no plan waits for a write, and of a
/// map's graphs for one robot only the newest waits to be written. No gRPC here.
#include <memory>
#include <optional>
#include <string>

#include "maps/graph_writer.hpp"
#include "maps/map_store.hpp"
#include "strata/planning/graph_archive.hpp"

namespace strata::server {

/// The graphs of terrain `terrain` of map `id` in `store`.
class StoredGraphs final : public GraphArchive {
 public:
  StoredGraphs(std::shared_ptr<MapStore> store, std::shared_ptr<GraphWriter> writer, std::string id,
               std::string terrain);

  /// The kept graph, or nullopt when none is kept or it does not load (logged).
  std::optional<SurfaceGraph> Find(const TerrainModel& model,
                                   const TraversabilityParams& params) const override;
  /// Whether the store holds a graph for `params` (its file exists).
  bool Holds(const TraversabilityParams& params) const override;
  /// Queues the graph's write (logged when it fails or is not queued); a graph of the map
  /// for the same robot still waiting is not written.
  void Keep(std::shared_ptr<const TerrainModel> model,
            std::shared_ptr<const SurfaceGraph> graph) const override;

 private:
  std::shared_ptr<MapStore> store_;
  std::shared_ptr<GraphWriter> writer_;
  std::string id_;
  std::string terrain_;
};

}  // namespace strata::server
