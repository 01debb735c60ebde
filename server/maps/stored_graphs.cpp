#include "maps/stored_graphs.hpp"

#include <chrono>
#include <string>
#include <utility>

#include "common/log.hpp"
#include "strata/io/saved_graph.hpp"

namespace strata::server {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

StoredGraphs::StoredGraphs(std::shared_ptr<MapStore> store, std::shared_ptr<GraphWriter> writer,
                           std::string id, std::string terrain)
    : store_(std::move(store)),
      writer_(std::move(writer)),
      id_(std::move(id)),
      terrain_(std::move(terrain)) {}

std::optional<SurfaceGraph> StoredGraphs::Find(const TerrainModel& model,
                                               const TraversabilityParams& params) const {
  const auto start = std::chrono::steady_clock::now();
  Result<std::optional<SurfaceGraph>> kept = store_->LoadGraph(id_, terrain_, model, params);
  if (!kept.ok()) {
    LogWarning("graph_not_loaded")
        .Add("map", id_)
        .Add("terrain", terrain_)
        .Add("reason", kept.error().message);
    return std::nullopt;
  }
  if (kept.value().has_value()) {
    LogInfo("graph_loaded")
        .Add("map", id_)
        .Add("terrain", terrain_)
        .Add("nodes", kept.value()->node_count())
        .Add("seconds", SecondsSince(start));
  }
  return std::move(kept).value();
}

bool StoredGraphs::Holds(const TraversabilityParams& params) const {
  return store_->HasGraph(id_, terrain_, params);
}

void StoredGraphs::Keep(std::shared_ptr<const TerrainModel> model,
                        std::shared_ptr<const SurfaceGraph> graph) const {
  // One key per map and robot: a newer terrain's graph takes the place of one still waiting.
  const std::string key = id_ + "/" + SavedGraphKey(graph->params());
  const bool queued = writer_->Keep(key, [store = store_, id = id_, terrain = terrain_,
                                          model = std::move(model), graph = std::move(graph)] {
    const auto start = std::chrono::steady_clock::now();
    if (ServiceStatus put = store->PutGraph(id, terrain, *graph); !put.ok()) {
      LogWarning("graph_not_kept").Add("map", id).Add("reason", put.error().message);
      return;
    }
    LogInfo("graph_kept")
        .Add("map", id)
        .Add("terrain", terrain)
        .Add("nodes", graph->node_count())
        .Add("seconds", SecondsSince(start));
  });
  if (!queued) {
    LogWarning("graph_not_kept")
        .Add("map", id_)
        .Add("reason", "the graph writer is busy: other replicas build this graph themselves");
  }
}

}  // namespace strata::server
