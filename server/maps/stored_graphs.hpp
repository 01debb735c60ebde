#pragma once
/// Robots' surface graphs kept in the map store beside the terrain they were built on
/// (MapStore::PutGraph), so that a replica that plans on a map loads a graph another replica
/// built instead of building it again (a kilometre's graph: seconds to build, a fraction of
/// that to load). Graphs are written on a thread of their own: no plan waits for a write.
/// No gRPC here.
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "maps/map_store.hpp"
#include "strata/planning/graph_archive.hpp"

namespace strata::server {

/// Graph writes waiting at most; more are not made (a replica that needs one builds it).
inline constexpr std::size_t kMaxGraphWritesWaiting = 4;

/// Runs graph writes one at a time on a thread of its own, in the order given.
class GraphWriter {
 public:
  GraphWriter();
  /// Waits for the write being made; those still waiting are not made.
  ~GraphWriter();
  GraphWriter(const GraphWriter&) = delete;
  GraphWriter& operator=(const GraphWriter&) = delete;

  /// Queues `write`; false (and `write` dropped) when kMaxGraphWritesWaiting already wait.
  bool Enqueue(std::function<void()> write);
  /// Returns once every write queued so far is made.
  void WaitIdle();

 private:
  void Run();

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> waiting_;
  bool writing_ = false;
  bool stopping_ = false;
  std::thread thread_;  // Last: started once the rest is ready.
};

/// The graphs of terrain `terrain` of map `id` in `store`.
class StoredGraphs final : public GraphArchive {
 public:
  StoredGraphs(std::shared_ptr<MapStore> store, std::shared_ptr<GraphWriter> writer, std::string id,
               std::string terrain);

  /// The kept graph, or nullopt when none is kept or it does not load (logged).
  std::optional<SurfaceGraph> Find(const TerrainModel& model,
                                   const TraversabilityParams& params) const override;
  /// Queues the graph's write (logged when it fails or is not queued).
  void Keep(std::shared_ptr<const TerrainModel> model,
            std::shared_ptr<const SurfaceGraph> graph) const override;

 private:
  std::shared_ptr<MapStore> store_;
  std::shared_ptr<GraphWriter> writer_;
  std::string id_;
  std::string terrain_;
};

}  // namespace strata::server
