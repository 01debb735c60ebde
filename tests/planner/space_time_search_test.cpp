// The route in space and time (fleet/space_time_search.hpp) on a hand-made floor with a block
// in its middle and a lane on either side: another robot drives the shorter lane towards the
// robot planned. Every route is checked against that robot's motion sampled every 10 ms, at
// the times the route gives, with the reach of the two bodies (the search's margins left
// out).
#include "fleet/space_time_search.hpp"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planner.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata::fleet_internal {
namespace {

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].
constexpr double kZ = 0.3;                                      // Reference height on the floor.
constexpr double kPassS = 18;  // How long the other robot takes through the south lane.

/// test_util::TwoLanes (a south and a north lane round a block, over x 3-9) at 0.1 m.
const PlanningMap& Site() {
  static const PlanningMap* map = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    return new PlanningMap(TerrainModel::Assess(test_util::TwoLanes(), config).value());
  }();
  return *map;
}

const RobotProfile& Profile() {
  static const RobotProfile profile = BuiltinProfile("differential").value();
  return profile;
}

const SurfaceGraph& Graph() { return *Site().Graph(Profile().Traversability()).value(); }

int NodeAt(double x, double y) {
  return SnapEndpoint(Graph(), {x, y, kZ}, 0.5, ErrorCode::kGoalOffGround).value().node;
}

/// A robot driving from rest at `from` to rest at `to` in `duration_s` (a quintic
/// smoothstep), leaving at the departure, gone when it arrives.
ReservedMotion Driving(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double duration_s) {
  TrajectoryPiece piece;
  piece.duration_s = duration_s;
  piece.coefficients = Eigen::MatrixXd::Zero(6, 3);
  const Eigen::Vector3d d = to - from;
  const double t = duration_s;
  piece.coefficients.row(0) = from.transpose();
  piece.coefficients.row(3) = (10 / (t * t * t)) * d.transpose();
  piece.coefficients.row(4) = (-15 / (t * t * t * t)) * d.transpose();
  piece.coefficients.row(5) = (6 / (t * t * t * t * t)) * d.transpose();
  ReservedMotion reserved;
  reserved.robot_id = "A";
  reserved.motion.start_ns = kDeparture;
  reserved.motion.trajectory.pieces = {piece};
  reserved.motion.body = FleetBody::FromProfile(Profile());
  reserved.motion.end_ns = reserved.motion.ArrivalNs();
  return reserved;
}

/// The other robot, through the south lane from east to west.
ReservedMotion ThroughTheSouthLane(double z_m = kZ) {
  return Driving({10.5, 0.6, z_m}, {1.5, 0.6, z_m}, kPassS);
}

Traffic TrafficOf(const std::vector<ReservedMotion>& others) {
  Traffic traffic;
  traffic.departure_ns = kDeparture;
  traffic.parked_until_ns = AddSeconds(kDeparture, 600);
  traffic.body = FleetBody::FromProfile(Profile());
  traffic.others = others;
  return traffic;
}

SpaceTimeOptions Options() {
  SpaceTimeOptions options;
  options.cost_per_s = 0.8;
  options.max_wait_s = 60;
  options.horizon_s = 120;
  return options;
}

std::optional<SpaceTimeRoute> Search(const std::vector<ReservedMotion>& others,
                                     const SpaceTimeOptions& options,
                                     const std::function<bool(int)>& blocked = {},
                                     const std::function<bool()>& should_stop = {}) {
  const Traffic traffic = TrafficOf(others);
  return SearchSpaceTime(Graph(), NodeAt(0.7, 3.0), NodeAt(11.3, 3.0), traffic, options, blocked,
                         should_stop);
}

/// Whether the route, timed as it says (at each node from its arrival to its leaving, and on
/// each move between), keeps the two bodies' reach from `other` at every 10 ms.
void ExpectClearOf(const SpaceTimeRoute& route, const ReservedMotion& other,
                   const SpaceTimeOptions& options) {
  const double reach_m = 2 * Profile().footprint_radius_m + SeparationRule{}.separation_m;
  const SurfaceGraph& graph = Graph();
  for (std::size_t k = 0; k < route.nodes.size(); ++k) {
    const Eigen::Vector3d at = graph.position(route.nodes[k]);
    const double arrival_s = route.leave_s[k] - route.wait_s[k];
    // Until it leaves, and on the move to the next node (at either end of it).
    double until_s = route.leave_s[k] + 0.5;
    if (k + 1 < route.nodes.size()) {
      until_s =
          route.leave_s[k] +
          graph.MoveCost(route.nodes[k], route.nodes[k + 1], options.terms) / options.cost_per_s;
    }
    for (double t = std::max(0.0, arrival_s - 0.1); t <= until_s; t += 0.01) {
      const std::int64_t t_ns = AddSeconds(kDeparture, t);
      if (t_ns > other.motion.end_ns) break;
      const Eigen::Vector3d p = other.motion.ReferencePointAt(t_ns);
      if (std::abs(p.z() - at.z()) > 1) continue;  // Another level.
      ASSERT_GT((p - at).head<2>().norm(), reach_m)
          << "node " << k << " at (" << at.x() << ", " << at.y() << ") at " << t << " s";
    }
  }
}

bool ThroughTheNorthLane(const SpaceTimeRoute& route) {
  return std::any_of(route.nodes.begin(), route.nodes.end(), [](int node) {
    const Eigen::Vector3d p = Graph().position(node);
    return p.x() > 4 && p.x() < 8 && p.y() > 5.8;
  });
}

double TotalWait(const SpaceTimeRoute& route) {
  double wait = 0;
  for (const double w : route.wait_s) wait += w;
  return wait;
}

TEST(SpaceTimeSearch, AloneTheRouteTakesTheShorterLaneWithoutWaitingAtTheMoveCostsPace) {
  const SpaceTimeOptions options = Options();
  const std::optional<SpaceTimeRoute> route = Search({}, options);
  ASSERT_TRUE(route);
  EXPECT_FALSE(ThroughTheNorthLane(*route));
  EXPECT_EQ(TotalWait(*route), 0);
  double cost = 0;
  for (std::size_t k = 0; k + 1 < route->nodes.size(); ++k) {
    cost += Graph().MoveCost(route->nodes[k], route->nodes[k + 1], options.terms);
  }
  EXPECT_NEAR(route->leave_s.back(), cost / options.cost_per_s, 1e-9);
}

TEST(SpaceTimeSearch, ARobotComingDownTheShorterLaneIsAvoidedByTheOtherLane) {
  const std::vector<ReservedMotion> others = {ThroughTheSouthLane()};
  const SpaceTimeOptions options = Options();
  const std::optional<SpaceTimeRoute> route = Search(others, options);
  ASSERT_TRUE(route);
  EXPECT_TRUE(ThroughTheNorthLane(*route));
  ExpectClearOf(*route, others[0], options);
}

TEST(SpaceTimeSearch, WithTheOtherLaneClosedTheRouteWaitsOutsideTheLaneForTheRobotToPass) {
  const std::vector<ReservedMotion> others = {ThroughTheSouthLane()};
  const SpaceTimeOptions options = Options();
  const std::optional<SpaceTimeRoute> route =
      Search(others, options, [](int node) { return Graph().position(node).y() > 5.8; });
  ASSERT_TRUE(route);
  EXPECT_FALSE(ThroughTheNorthLane(*route));
  // It cannot enter the lane before the other robot has left it, at kPassS at the latest.
  EXPECT_GT(TotalWait(*route), 1.0);
  ExpectClearOf(*route, others[0], options);
  // Without the time to wait, there is no route.
  SpaceTimeOptions impatient = options;
  impatient.max_wait_s = 1;
  EXPECT_FALSE(
      Search(others, impatient, [](int node) { return Graph().position(node).y() > 5.8; }));
}

TEST(SpaceTimeSearch, WithTheOtherLaneClosedTheRouteGoesThroughTheGapBetweenTwoRobots) {
  // Two robots through the south lane, the second leaving kGapS after the first: the lane is
  // free between their passages, long enough for the route to cross it.
  constexpr double kGapS = 60;
  ReservedMotion second = ThroughTheSouthLane();
  second.robot_id = "B";
  second.motion.start_ns = AddSeconds(kDeparture, kGapS);
  second.motion.end_ns = second.motion.ArrivalNs();
  const std::vector<ReservedMotion> others = {ThroughTheSouthLane(), second};
  const SpaceTimeOptions options = Options();
  const std::optional<SpaceTimeRoute> route =
      Search(others, options, [](int node) { return Graph().position(node).y() > 5.8; });
  ASSERT_TRUE(route);
  EXPECT_GT(TotalWait(*route), 1.0);        // For the first robot to pass.
  EXPECT_LT(route->leave_s.back(), kGapS);  // Across before the second one.
  ExpectClearOf(*route, others[0], options);
  ExpectClearOf(*route, others[1], options);
}

TEST(SpaceTimeSearch, ARobotAtAnotherHeightIsNotInTheWay) {
  // The same way, 3 m up (a deck over the lane): the bodies never overlap in height.
  const std::optional<SpaceTimeRoute> route = Search({ThroughTheSouthLane(3.3)}, Options());
  ASSERT_TRUE(route);
  EXPECT_FALSE(ThroughTheNorthLane(*route));
  EXPECT_EQ(TotalWait(*route), 0);
}

TEST(SpaceTimeSearch, AStartWithinReachOfAnotherRobotAtTheDepartureHasNoRoute) {
  const std::vector<ReservedMotion> others = {Driving({0.9, 3.0, kZ}, {0.9, 6.5, kZ}, 5)};
  EXPECT_FALSE(Search(others, Options()));
}

/// Whether a search among `others` fails before it expands anything: it polls should_stop
/// every 1024 states, and would poll it while flooding the floor within the wait allowed.
void ExpectNoRouteAtOnce(const std::vector<ReservedMotion>& others) {
  int polls = 0;
  EXPECT_FALSE(Search(others, Options(), {}, [&polls] {
    ++polls;
    return false;
  }));
  EXPECT_EQ(polls, 0);
}

TEST(SpaceTimeSearch, AGoalWhereAnotherRobotStaysBeyondTheHorizonHasNoRoute) {
  ReservedMotion parked = Driving({11.3, 2.8, kZ}, {11.3, 3.1, kZ}, 1);
  parked.motion.end_ns = AddSeconds(kDeparture, 600);
  ExpectNoRouteAtOnce({parked});
}

TEST(SpaceTimeSearch, AGoalAnotherRobotComesToStayAtHasNoRoute) {
  // Free until that robot arrives from the north lane's end, 20 s after the departure: the
  // robot planned could be there first, but could not stay.
  ReservedMotion arriving = Driving({11.3, 6.5, kZ}, {11.3, 3.1, kZ}, 20);
  arriving.motion.end_ns = AddSeconds(kDeparture, 600);
  ExpectNoRouteAtOnce({arriving});
}

}  // namespace
}  // namespace strata::fleet_internal
