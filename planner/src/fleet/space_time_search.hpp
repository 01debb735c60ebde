#pragma once
/// A route over the surface graph that keeps out of the other robots' way in space and time:
/// Safe Interval Path Planning (SIPP; Phillips and Likhachev, 2011) on the graph's nodes, with
/// waiting. Each node's time is cut into safe intervals, between the moments another robot
/// passes within reach of it (or stands there); the search's states are (node, safe
/// interval), each reached at its earliest time, so it may wait at a node for another robot
/// to pass, pull aside into a bay, or take another aisle, and finds the earliest arrival
/// under its model of the robot's timing.
///
/// That model is coarse on purpose: the robot crosses each edge at a constant speed, and the
/// others' ways are widened by a margin in space and time that covers the difference between
/// the graph's route and the optimised trajectory that will follow it. The route it gives is
/// a guide, not a commitment: PlanAmongTraffic plans the trajectory through it and checks
/// its departures exactly (hold_schedule.hpp).
#include <functional>
#include <optional>
#include <vector>

#include "strata/fleet/traffic.hpp"
#include "strata/planning/surface_graph.hpp"

namespace strata::fleet_internal {

struct SpaceTimeOptions {
  /// The robot's mean speed along the route, in move cost per second (MoveCost under `terms`
  /// over time): a plan's path cost over its trajectory's duration matches its timing.
  double cost_per_s = 0.5;
  MoveCostTerms terms;
  /// Added to the sum of the two radii and the separation around another robot's way [m]:
  /// the trajectory cuts the graph's corners.
  double margin_m = 0.25;
  /// Added before and after each moment another robot is within reach of a node [s], plus
  /// `time_drift` of the time since the departure: the trajectory's timing drifts from the
  /// route's as it goes (a route searched on the garage ran 5–15% slower than the trajectory
  /// then planned through it). Tuned on fleet_benchmark (docs/design.md, "Fleets").
  double time_margin_s = 2.0;
  double time_drift = 0.08;
  /// Longest the route may wait in all [s]; a route waiting longer is not searched on.
  double max_wait_s = 60;
  /// Others' motions are looked at up to this long after the departure [s]; a route
  /// arriving later is not searched on.
  double horizon_s = 300;
  /// Weight on the heuristic (the straight line and the landmarks' bound) [-], >= 1: the
  /// route found arrives at most this many times later than the earliest, in fewer states.
  double heuristic_weight = 1.1;
  int max_states = 200'000;  ///< Most (node, interval) states the search may expand.
};

/// The route found: graph nodes from the start node to the goal node, when the robot leaves
/// each under the search's timing, and how long it waits there first [s, from the departure].
struct SpaceTimeRoute {
  std::vector<int> nodes;
  std::vector<double> leave_s;
  std::vector<double> wait_s;
  int expansions = 0;
};

/// The earliest route from `start_node` to `goal_node` that keeps clear of `traffic.others`
/// under `options`, staying at the goal from its arrival on; none when the start is within
/// reach of another robot at the departure, the goal is within reach of one at the horizon
/// (both found before any state is expanded), the budget runs out, `should_stop` (may be
/// empty) says so, or there is no such route. `blocked` (may be empty) keeps nodes out, as the
/// plan's keep-out zones do.
std::optional<SpaceTimeRoute> SearchSpaceTime(const SurfaceGraph& graph, int start_node,
                                              int goal_node, const Traffic& traffic,
                                              const SpaceTimeOptions& options,
                                              const std::function<bool(int)>& blocked,
                                              const std::function<bool()>& should_stop);

}  // namespace strata::fleet_internal
