#pragma once
/// Robots' surface graphs kept in the map store beside the terrain they were built on
/// (MapStore::PutGraph), so that a replica that plans on a map loads a graph another replica
/// built instead of building it again (a kilometre's graph: seconds to build, a fraction of
/// that to load). Graphs are written on a thread of their own: no plan waits for a write.
/// No gRPC here.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "common/job_threads.hpp"
#include "maps/map_store.hpp"
#include "strata/planning/graph_archive.hpp"

namespace strata::server {

/// Graph writes waiting at most; more are not made (a replica that needs one builds it).
inline constexpr std::size_t kMaxGraphWritesWaiting = 4;

/// The thread graphs are written on, one at a time, in the order kept.
std::shared_ptr<JobThreads> MakeGraphWriter();

/// The graphs of terrain `terrain` of map `id` in `store`.
class StoredGraphs final : public GraphArchive {
 public:
  StoredGraphs(std::shared_ptr<MapStore> store, std::shared_ptr<JobThreads> writer, std::string id,
               std::string terrain);

  /// The kept graph, or nullopt when none is kept or it does not load (logged).
  std::optional<SurfaceGraph> Find(const TerrainModel& model,
                                   const TraversabilityParams& params) const override;
  /// Whether the store holds a graph for `params` (its file exists).
  bool Holds(const TraversabilityParams& params) const override;
  /// Queues the graph's write (logged when it fails or is not queued).
  void Keep(std::shared_ptr<const TerrainModel> model,
            std::shared_ptr<const SurfaceGraph> graph) const override;

 private:
  std::shared_ptr<MapStore> store_;
  std::shared_ptr<JobThreads> writer_;
  std::string id_;
  std::string terrain_;
};

}  // namespace strata::server
