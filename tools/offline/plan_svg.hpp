#pragma once
// A drawing of one plan for people, as a standalone SVG: a top view of the traversable ground
// with the A* path and the trajectory coloured by speed, and a side view of heights along the
// trajectory (ground, reference point, body top, ceiling).

#include <string>

#include "strata/planner.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata::offline {

/// The SVG document (UTF-8) of `plan`. `graph` is the surface graph the plan was searched on
/// (PlanningMap::Graph(profile.Traversability())); its model gives the ground and ceiling
/// under the trajectory. `map_name` goes into the title. Precondition: the trajectory has at
/// least one piece and the graph at least one node, as every successful plan does.
std::string RenderPlanSvg(const SurfaceGraph& graph, const PlanResult& plan,
                          const RobotProfile& profile, const std::string& map_name);

}  // namespace strata::offline
