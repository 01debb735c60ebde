#pragma once
// A site for the fleet benchmarks: a planning map and the reference points of its largest
// connected ground, where robots start and take their goals.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "compare/bench_pairs.hpp"
#include "strata/planner.hpp"

namespace strata::bench {

struct FleetSite {
  std::string name;
  std::unique_ptr<PlanningMap> map;
  std::vector<Eigen::Vector3d> nodes;  // Reference points of the largest component.
};

/// `cloud` assessed at `resolution_m`; nullopt (with the reason printed) when it fails.
inline std::optional<FleetSite> MakeFleetSite(const std::string& name, const PointCloud& cloud,
                                              double resolution_m, const RobotProfile& profile) {
  AssessmentConfig config;
  config.grid.resolution_m = resolution_m;
  auto model = TerrainModel::Assess(cloud, config);
  if (!model) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), model.error().message.c_str());
    return std::nullopt;
  }
  FleetSite site{name, std::make_unique<PlanningMap>(std::move(model).value()), {}};
  auto graph = site.map->Graph(profile.Traversability());
  if (!graph) return std::nullopt;
  const auto component = FindLargestComponent(*graph.value());
  for (int node : component.nodes) site.nodes.push_back(graph.value()->position(node));
  return site;
}

}  // namespace strata::bench
