// Planning one robot among others' committed motions, on a hand-made site: a head-on meeting
// on a one-lane ramp, a crossing on an open floor, a robot passing under another on a deck,
// and robots parked in the way. Every plan is checked by sampling every millisecond.
#include "strata/fleet/fleet_plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/terrain_model.hpp"
#include "test_util/hand_made_maps.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

constexpr std::int64_t kDeparture = 1'795'000'000'000'000'000;  // A time in 2026 [ns].
constexpr double kLeaseS = 600;
constexpr double kRampRiseM = 0.5;

/// A site 16 × 9 m: a floor at z = 0 (x 0-6), a one-lane ramp between walls (x 6-11, the lane
/// 1 m wide around y = 4.5) up to a plateau at 0.5 m (x 11-16), and a deck 2 m over the floor
/// (x 1-5, y 5.5-7.5) that is an island of its own. Points 5 cm apart.
PointCloud FleetSite() {
  test_util::CloudBuilder b(0.05);
  b.Plate(0, 5.95, 0, 9, 0.0);
  b.Surface(6, 11, 4.0, 5.0, [](double x, double) { return (x - 6) / 5 * kRampRiseM; });
  b.Block(6, 11, 3.7, 3.85, 0, 2.5);
  b.Block(6, 11, 5.15, 5.3, 0, 2.5);
  b.Plate(11.05, 16, 0, 9, kRampRiseM);
  b.Plate(1, 5, 5.5, 7.5, 2.0);
  return b.cloud();
}

const PlanningMap& Site() {
  static const PlanningMap* map = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    return new PlanningMap(TerrainModel::Assess(FleetSite(), config).value());
  }();
  return *map;
}

const RobotProfile& Profile() {
  static const RobotProfile profile = BuiltinProfile("differential").value();
  return profile;
}

PlanRequest Between(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  PlanRequest request;
  request.start.position_m = from;
  request.goal.position_m = to;
  request.profile = Profile();
  return request;
}

FleetPlanRequest AmongOthers(const PlanRequest& plan, const std::vector<ReservedMotion>& others) {
  FleetPlanRequest request;
  request.plan = plan;
  request.departure_ns = kDeparture;
  request.parked_until_ns = AddSeconds(kDeparture, kLeaseS);
  request.others = others;
  return request;
}

/// A robot's committed motion: `plan` planned alone, leaving at the departure.
ReservedMotion Committed(const std::string& robot, const PlanRequest& plan) {
  Expected<PlanResult> result = Plan(Site(), plan);
  EXPECT_TRUE(result) << result.error().message;
  ReservedMotion reserved;
  reserved.robot_id = robot;
  reserved.motion.start_ns = kDeparture;
  reserved.motion.trajectory = result.value().trajectory;
  reserved.motion.body = FleetBody::FromProfile(plan.profile);
  reserved.motion.end_ns = AddSeconds(kDeparture, kLeaseS);
  return reserved;
}

/// A robot standing at `at` for the whole lease.
ReservedMotion Parked(const std::string& robot, const Eigen::Vector3d& at) {
  ReservedMotion reserved;
  reserved.robot_id = robot;
  reserved.motion.start_ns = kDeparture;
  TrajectoryPiece stand;
  stand.duration_s = 0.1;
  stand.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  stand.coefficients.row(0) = at.transpose();
  reserved.motion.trajectory.pieces.push_back(stand);
  reserved.motion.body = FleetBody::FromProfile(Profile());
  reserved.motion.end_ns = AddSeconds(kDeparture, kLeaseS);
  return reserved;
}

// The test's own conflict check: both motions sampled every millisecond.
struct Sampled {
  bool conflict = false;
  double closest_horizontal_m = 1e9;  // Over the moments both exist.
};

Sampled SampleEveryMillisecond(const FleetMotion& a, const FleetMotion& b, double limit_m) {
  Sampled s;
  const std::int64_t until = std::min(a.end_ns, b.end_ns);
  for (std::int64_t t = std::max(a.start_ns, b.start_ns); t <= until; t += 1'000'000) {
    const Eigen::Vector3d pa = a.ReferencePointAt(t);
    const Eigen::Vector3d pb = b.ReferencePointAt(t);
    const double bottom_a = pa.z() - a.body.reference_height_m;
    const double bottom_b = pb.z() - b.body.reference_height_m;
    const bool overlap =
        bottom_a < bottom_b + b.body.height_m && bottom_b < bottom_a + a.body.height_m;
    const double d = (pa - pb).head<2>().norm();
    s.closest_horizontal_m = std::min(s.closest_horizontal_m, d);
    s.conflict = s.conflict || (overlap && d < limit_m);
  }
  return s;
}

double Limit() { return 2 * Profile().footprint_radius_m + SeparationRule{}.separation_m; }

void ExpectClearOfAll(const FleetMotion& motion, const std::vector<ReservedMotion>& others) {
  for (const ReservedMotion& other : others) {
    EXPECT_FALSE(SampleEveryMillisecond(motion, other.motion, Limit()).conflict)
        << "meets " << other.robot_id;
  }
}

using NamedMotions = std::vector<std::pair<std::string, const FleetMotion*>>;

/// With STRATA_FLEET_SCENARIO_DIR set, writes `motions` to <dir>/<scenario>.csv (robot, t_s,
/// x, y, z every 50 ms from the departure to a second after the last arrival), for
/// bench/plots/plot_fleet_scenarios.py's pictures in docs/design.md §19; else nothing.
void WriteScenario(const std::string& scenario, const NamedMotions& motions) {
  const char* dir = std::getenv("STRATA_FLEET_SCENARIO_DIR");
  if (dir == nullptr) return;
  std::int64_t last_arrival = kDeparture;
  for (const auto& [robot, motion] : motions) {
    last_arrival = std::max(last_arrival, motion->ArrivalNs());
  }
  std::ofstream out(std::string(dir) + "/" + scenario + ".csv");
  out << std::fixed << std::setprecision(4) << "robot,t_s,x,y,z\n";
  for (const auto& [robot, motion] : motions) {
    for (std::int64_t t = kDeparture; t <= AddSeconds(last_arrival, 1); t += 50'000'000) {
      const Eigen::Vector3d p = motion->ReferencePointAt(std::max(t, motion->start_ns));
      out << robot << ',' << SecondsBetween(kDeparture, t) << ',' << p.x() << ',' << p.y() << ','
          << p.z() << '\n';
    }
  }
  ASSERT_TRUE(out.good()) << "could not write " << scenario << ".csv to " << dir;
}

/// Plans alone, then among `others`: the lone plan must meet them (else the case tests
/// nothing), the fleet plan must not. Writes the scenario (WriteScenario) as `scenario`.
FleetPlanResult PlanBoth(const std::string& scenario, const PlanRequest& plan,
                         const std::vector<ReservedMotion>& others) {
  const FleetPlanRequest request = AmongOthers(plan, others);
  const ReservedMotion alone = Committed("alone", plan);
  bool met = false;
  for (const ReservedMotion& other : others) {
    met = met || SampleEveryMillisecond(alone.motion, other.motion, Limit()).conflict;
  }
  EXPECT_TRUE(met) << "planned alone, the robot would not meet the others";
  Expected<FleetPlanResult> result = PlanAmongTraffic(Site(), request);
  EXPECT_TRUE(result) << result.error().message;
  if (!result) return {};
  ExpectClearOfAll(result.value().motion, others);
  NamedMotions motions = {{"B alone", &alone.motion}, {"B", &result.value().motion}};
  for (const ReservedMotion& other : others) motions.emplace_back(other.robot_id, &other.motion);
  WriteScenario(scenario, motions);
  return std::move(result).value();
}

/// `request` planned whole, then stopped by its caller at each of the polls the whole plan made
/// in turn: each answer is kCancelled, never a refusal or a plan, whatever step the plan had
/// reached (the optimiser, the exact checks, the stop search, making way at the goal).
void ExpectCancelledWhereverStopped(const FleetPlanRequest& request) {
  int polls = 0;
  const Expected<FleetPlanResult> whole = PlanAmongTraffic(Site(), request, [&] {
    ++polls;
    return false;
  });
  ASSERT_TRUE(whole) << whole.error().message;
  for (int stop_at = 1; stop_at <= polls; ++stop_at) {
    int calls = 0;
    const Expected<FleetPlanResult> stopped =
        PlanAmongTraffic(Site(), request, [&] { return ++calls >= stop_at; });
    ASSERT_FALSE(stopped) << "planned though stopped at poll " << stop_at << " of " << polls;
    EXPECT_EQ(stopped.error().code, ErrorCode::kCancelled)
        << "stopped at poll " << stop_at << " of " << polls << ": " << stopped.error().message;
  }
}

TEST(FleetPlan, HeadOnOnAOneLaneRampTheLaterRobotWaitsForTheLaneToClear) {
  // A drives up the ramp from the floor to the plateau; B, committed later, drives down.
  const std::vector<ReservedMotion> others = {
      Committed("A", Between({2, 4.5, 0.3}, {14.5, 4.5, 0.8}))};
  const FleetPlanResult b =
      PlanBoth("head_on_ramp", Between({13, 7.5, 0.8}, {2, 1.5, 0.3}), others);
  EXPECT_GT(b.wait_s, 0);
  EXPECT_EQ(b.plan.trajectory.pieces.front().duration_s, b.wait_s);
  EXPECT_DOUBLE_EQ(b.plan.stats.duration_s, b.plan.trajectory.TotalDuration());
}

TEST(FleetPlan, ARobotThatCannotWaitAtItsStartWaitsOnItsWayForTheLaneToClear) {
  // As above, A drives up the ramp and B, later, down; C crosses the plateau just beside B's
  // start, so B cannot wait there for A: it drives off and waits on the way, out of A's.
  const std::vector<ReservedMotion> others = {
      Committed("A", Between({2, 4.5, 0.3}, {14.5, 4.5, 0.8})),
      Committed("C", Between({13.5, 1.0, 0.8}, {13.5, 8.5, 0.8}))};
  const FleetPlanResult b =
      PlanBoth("wait_on_the_way", Between({13, 7.5, 0.8}, {2, 1.5, 0.3}), others);
  EXPECT_GE(b.stops_added, 1);
  ASSERT_FALSE(b.holds.empty());
  EXPECT_GT(b.holds.back().start_s, 0) << "the robot waits on its way, not only at its start";
  double waited_s = 0;
  for (const FleetHold& hold : b.holds) {
    waited_s += hold.duration_s;
    // Each hold is a piece at rest where it says.
    EXPECT_TRUE(b.plan.trajectory.Velocity(hold.start_s + hold.duration_s / 2).isZero(1e-9));
    EXPECT_LT(
        (b.plan.trajectory.Position(hold.start_s + hold.duration_s / 2).head<3>() - hold.position_m)
            .norm(),
        1e-9);
  }
  EXPECT_DOUBLE_EQ(waited_s, b.wait_s);
  EXPECT_LE(b.wait_s, FleetPlanOptions{}.max_wait_s);
  EXPECT_DOUBLE_EQ(b.plan.stats.duration_s, b.plan.trajectory.TotalDuration());
  // Among its polls are the stop search's.
  ExpectCancelledWhereverStopped(AmongOthers(Between({13, 7.5, 0.8}, {2, 1.5, 0.3}), others));
}

TEST(FleetPlan, AtAFourWayCrossingTheLaterRobotLetsTheOtherPass) {
  const std::vector<ReservedMotion> others = {
      Committed("A", Between({0.5, 2.5, 0.3}, {5.5, 2.5, 0.3}))};
  const FleetPlanResult b =
      PlanBoth("four_way_crossing", Between({3, 0.5, 0.3}, {3, 4.5, 0.3}), others);
  EXPECT_GT(b.wait_s, 0);
  EXPECT_LT(b.wait_s, 10);
}

TEST(FleetPlan, ARobotThatAskedForMoreSeparationIsGivenItByARobotPlannedAfterIt) {
  // The crossing above, A's reservation asking 1 m between bodies: B, planned with the default
  // 0.1 m, keeps 1 m from it. Planned as if A asked nothing, B comes closer than that.
  ReservedMotion a = Committed("A", Between({0.5, 2.5, 0.3}, {5.5, 2.5, 0.3}));
  const PlanRequest b_plan = Between({3, 0.5, 0.3}, {3, 4.5, 0.3});
  const double wide_limit_m = 2 * Profile().footprint_radius_m + 1.0;
  Expected<FleetPlanResult> narrow = PlanAmongTraffic(Site(), AmongOthers(b_plan, {a}));
  ASSERT_TRUE(narrow) << narrow.error().message;
  ASSERT_TRUE(SampleEveryMillisecond(narrow.value().motion, a.motion, wide_limit_m).conflict)
      << "with A asking nothing more, B keeps 1 m anyway: the case tests nothing";
  a.motion.separation_m = 1.0;
  Expected<FleetPlanResult> wide = PlanAmongTraffic(Site(), AmongOthers(b_plan, {a}));
  ASSERT_TRUE(wide) << wide.error().message;
  EXPECT_FALSE(SampleEveryMillisecond(wide.value().motion, a.motion, wide_limit_m).conflict);
  EXPECT_GT(wide.value().wait_s, narrow.value().wait_s);
  // B's own motion asks what its plan's rule says.
  EXPECT_EQ(wide.value().motion.separation_m, SeparationRule{}.separation_m);
}

TEST(FleetPlan, ARobotUnderADeckPassesOneOnTheDeckWithoutWaiting) {
  // A crosses the deck along x while B crosses the floor under it along y, at the same time.
  const std::vector<ReservedMotion> others = {
      Committed("A", Between({1.5, 6.5, 2.3}, {4.5, 6.5, 2.3}))};
  const PlanRequest b_request = Between({3, 4.6, 0.3}, {3, 8.5, 0.3});
  Expected<FleetPlanResult> b = PlanAmongTraffic(Site(), AmongOthers(b_request, others));
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_EQ(b.value().wait_s, 0);
  EXPECT_EQ(b.value().parked_robots_avoided, 0);
  // They do pass within the limit horizontally: only the heights keep them apart.
  const Sampled s = SampleEveryMillisecond(b.value().motion, others[0].motion, Limit());
  EXPECT_FALSE(s.conflict);
  EXPECT_LT(s.closest_horizontal_m, Limit());
  WriteScenario("under_the_deck", {{"B", &b.value().motion}, {"A", &others[0].motion}});
}

TEST(FleetPlan, ARobotParkedInTheWayIsDrivenAround) {
  const std::vector<ReservedMotion> others = {Parked("C", {3, 2.5, 0.3})};
  const FleetPlanResult b =
      PlanBoth("parked_in_the_way", Between({0.5, 2.5, 0.3}, {5.5, 2.5, 0.3}), others);
  EXPECT_EQ(b.parked_robots_avoided, 1);
  EXPECT_EQ(b.wait_s, 0);
}

TEST(FleetPlan, AGoalOrStartWhereAnotherRobotIsParkedIsRefusedNamingIt) {
  const std::vector<ReservedMotion> others = {Parked("C", {5.5, 2.5, 0.3})};
  Expected<FleetPlanResult> to_c =
      PlanAmongTraffic(Site(), AmongOthers(Between({0.5, 2.5, 0.3}, {5.4, 2.6, 0.3}), others));
  ASSERT_FALSE(to_c);
  EXPECT_EQ(to_c.error().code, ErrorCode::kReservationConflict);
  EXPECT_THAT(to_c.error().message, HasSubstr("the goal is where robot 'C' stays parked"));
  EXPECT_EQ(to_c.error().details.at("robot_id"), "C");

  Expected<FleetPlanResult> from_c =
      PlanAmongTraffic(Site(), AmongOthers(Between({5.3, 2.5, 0.3}, {0.5, 2.5, 0.3}), others));
  ASSERT_FALSE(from_c);
  EXPECT_EQ(from_c.error().code, ErrorCode::kReservationConflict);
  EXPECT_THAT(from_c.error().message, HasSubstr("robot 'C'"));
}

// A start 1 cm clear of the limit from a robot parked across the way: exactly clear, but
// inside the zone the planner puts around that robot (2 cm wider than the limit). The zone
// turns an edge towards the start and narrows, so the robot leaves round it. Parked for the
// whole lease (found by the rounds) and for longer than any trip (zoned before the first plan).
TEST(FleetPlan, AStartExactlyClearOfARobotParkedInTheWayIsNotRefused) {
  for (const double parked_s : {kLeaseS, 2 * kLeaseS}) {
    std::vector<ReservedMotion> others = {Parked("C", {3, 2.5, 0.3})};
    others[0].motion.end_ns = AddSeconds(kDeparture, parked_s);
    const Eigen::Vector3d start(3, 2.5 - Limit() - 0.01, 0.3);
    FleetPlanRequest request = AmongOthers(Between(start, {3, 4.5, 0.3}), others);
    request.parked_until_ns = AddSeconds(kDeparture, parked_s);
    Expected<FleetPlanResult> b = PlanAmongTraffic(Site(), request);
    ASSERT_TRUE(b) << "parked for " << parked_s << " s: " << b.error().message;
    EXPECT_EQ(b.value().parked_robots_avoided, 1);
    ExpectClearOfAll(b.value().motion, others);
  }
}

// A robot on its way, replanned, may start where another robot parks only later: it must leave
// before that one arrives, which the waits check, and is not refused as if that robot stood
// there already.
TEST(FleetPlan, AStartAnotherRobotParksOnOnlyLaterIsLeftInTime) {
  const Eigen::Vector3d start(3, 2.5, 0.3);
  const std::vector<ReservedMotion> others = {Committed("C", Between({0.7, 0.7, 0.3}, start))};
  ASSERT_GT(others[0].motion.ArrivalNs(), kDeparture);
  Expected<FleetPlanResult> b =
      PlanAmongTraffic(Site(), AmongOthers(Between(start, {5.5, 6.0, 0.3}), others));
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_EQ(b.value().parked_robots_avoided, 0);
  ExpectClearOfAll(b.value().motion, others);
}

/// test_util::TwoLanes at 0.1 m.
const PlanningMap& TwoLaneSite() {
  static const PlanningMap* map = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    return new PlanningMap(TerrainModel::Assess(test_util::TwoLanes(), config).value());
  }();
  return *map;
}

/// Robot `id` driving `plan` on the two-lane site from the departure, gone on arrival.
ReservedMotion GoneOnArrival(const std::string& id, const PlanRequest& plan) {
  Expected<PlanResult> planned = Plan(TwoLaneSite(), plan);
  EXPECT_TRUE(planned) << planned.error().message;
  ReservedMotion other;
  other.robot_id = id;
  other.motion.start_ns = kDeparture;
  if (planned) other.motion.trajectory = planned.value().trajectory;
  other.motion.body = FleetBody::FromProfile(Profile());
  other.motion.end_ns = other.motion.ArrivalNs();
  return other;
}

/// Robot A driving the two-lane site's south lane west from the departure, gone on arrival.
ReservedMotion SouthLaneWestbound() {
  return GoneOnArrival("A", Between({10.5, 0.6, 0.3}, {1.2, 0.6, 0.3}));
}

/// Whether `trajectory` passes through the two-lane site's north lane.
bool TakesTheNorthLane(const Trajectory& trajectory) {
  for (double t = 0; t < trajectory.TotalDuration(); t += 0.1) {
    const Eigen::Vector3d p = trajectory.Position(t).head<3>();
    if (p.x() > 4 && p.x() < 8 && p.y() > 5.8) return true;
  }
  return false;
}

TEST(FleetPlan, ARobotComingDownTheShorterLaneLongerThanTheRobotMayWaitIsAvoidedByTheOtherLane) {
  // A drives the south lane west and is gone; B, going east, may wait 5 s only, and A takes
  // longer than that to clear the lane.
  const ReservedMotion other = SouthLaneWestbound();
  const std::vector<ReservedMotion> others = {other};
  FleetPlanRequest request = AmongOthers(Between({0.7, 3.0, 0.3}, {11.3, 3.0, 0.3}), others);
  request.fleet.max_wait_s = 5;

  Expected<PlanResult> alone = Plan(TwoLaneSite(), request.plan);
  ASSERT_TRUE(alone) << alone.error().message;
  FleetMotion alone_motion = other.motion;
  alone_motion.trajectory = alone.value().trajectory;
  alone_motion.end_ns = alone_motion.ArrivalNs();
  ASSERT_TRUE(SampleEveryMillisecond(alone_motion, other.motion, Limit()).conflict)
      << "planned alone, B would not meet A";

  Expected<FleetPlanResult> result = PlanAmongTraffic(TwoLaneSite(), request);
  ASSERT_TRUE(result) << result.error().message;
  ExpectClearOfAll(result.value().motion, others);
  EXPECT_TRUE(TakesTheNorthLane(result.value().plan.trajectory)) << "B did not take the north lane";
  EXPECT_LE(result.value().wait_s, 5);
}

/// A and A2 driving the two-lane site's south lane west, A2 6 s after A (B waits 5 s at most:
/// neither a wait nor a stop clears both), and C driving south at `c_x` past B's start (0.7,
/// 3.0) from the departure.
std::vector<ReservedMotion> TwoInTheSouthLaneAndOnePassingBsStartAt(double c_x) {
  ReservedMotion a2 = SouthLaneWestbound();
  a2.robot_id = "A2";
  a2.motion.start_ns = AddSeconds(kDeparture, 6);
  a2.motion.end_ns = a2.motion.ArrivalNs();
  return {SouthLaneWestbound(), a2, GoneOnArrival("C", Between({c_x, 4.4, 0.3}, {c_x, 1.9, 0.3}))};
}

/// B going east through the two lanes among `others`, waiting 5 s at most, in a request that
/// may replan others (none of them may be): such a request tries later departures.
FleetPlanRequest BEastThroughTheLanesMayReplan(const std::vector<ReservedMotion>& others) {
  FleetPlanRequest request = AmongOthers(Between({0.7, 3.0, 0.3}, {11.3, 3.0, 0.3}), others);
  request.fleet.replan.max_robots = 1;
  request.fleet.max_wait_s = 5;
  return request;
}

// B goes east through the two lanes while A and A2 come west along the south lane, and C drives
// south past B's start at the departure, 0.85 m from it: clear of B standing there (the limit
// is 0.7 m), but within the space-time search's reach of B's start node (0.95 m), so that the
// search at the departure finds the start busy and no route (without C, B takes the north lane
// at once). Nothing planned at the departure clears A and A2; 5 s later C has gone, and the
// route searched then takes the north lane. B, whose request may replan others, holds at its
// start for those 5 s, its whole wait.
TEST(FleetPlan, ARobotNothingClearsAtItsDepartureHoldsAtItsStartAndLeavesLater) {
  const std::vector<ReservedMotion> others = TwoInTheSouthLaneAndOnePassingBsStartAt(1.55);
  FleetPlanRequest request = BEastThroughTheLanesMayReplan(others);
  // Less than the 5 s a later departure takes: refused at the departure.
  request.fleet.max_wait_s = 4.9;
  Expected<FleetPlanResult> now = PlanAmongTraffic(TwoLaneSite(), request);
  ASSERT_FALSE(now) << "planned at the departure: the case tests nothing";
  EXPECT_EQ(now.error().code, ErrorCode::kReservationConflict);
  // In commit order: no later departures.
  request.fleet.max_wait_s = 5;
  request.fleet.replan.max_robots = 0;
  Expected<FleetPlanResult> in_order = PlanAmongTraffic(TwoLaneSite(), request);
  ASSERT_FALSE(in_order) << "planned at the departure in commit order";

  request.fleet.replan.max_robots = 1;
  Expected<FleetPlanResult> later = PlanAmongTraffic(TwoLaneSite(), request);
  ASSERT_TRUE(later) << later.error().message;
  const FleetPlanResult& b = later.value();
  ExpectClearOfAll(b.motion, others);
  EXPECT_TRUE(TakesTheNorthLane(b.plan.trajectory)) << "B did not take the north lane";
  ASSERT_EQ(b.holds.size(), 1U);
  EXPECT_EQ(b.holds.front().start_s, 0);
  EXPECT_DOUBLE_EQ(b.holds.front().duration_s, 5);
  EXPECT_DOUBLE_EQ(b.wait_s, 5);
  EXPECT_DOUBLE_EQ(b.plan.trajectory.pieces.front().duration_s, 5);
  EXPECT_TRUE(b.plan.trajectory.EvaluatePiece(0, 2.5, 1).isZero(1e-12)) << "B moves while it holds";
  EXPECT_EQ(b.motion.start_ns, kDeparture);
  EXPECT_NEAR(b.plan.stats.duration_s, b.plan.trajectory.TotalDuration(), 1e-9);
  EXPECT_NEAR(b.arrival_s, b.plan.stats.duration_s, 1e-9);
}

// As above, with C passing 0.6 m from B's start, within the limit: B may not hold there while C
// passes, so it may not leave later either (nor now).
TEST(FleetPlan, ARobotThatMayNotHoldAtItsStartIsNotPlannedToLeaveLater) {
  const std::vector<ReservedMotion> others = TwoInTheSouthLaneAndOnePassingBsStartAt(1.3);
  Expected<FleetPlanResult> refused =
      PlanAmongTraffic(TwoLaneSite(), BEastThroughTheLanesMayReplan(others));
  if (refused) ExpectClearOfAll(refused.value().motion, others);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kReservationConflict);
}

/// B through the two lanes as above (A in the south lane, B waiting 5 s at most) with one more
/// robot parked at `at`: B takes the north lane, clear of both, planning around the parked
/// robot in two plans (the plain route, then the route through the search's guides), not three.
void ExpectTheNorthLaneInTwoPlansAroundOneParkedAt(const Eigen::Vector3d& at) {
  const std::vector<ReservedMotion> others = {SouthLaneWestbound(), Parked("P", at)};
  FleetPlanRequest request = AmongOthers(Between({0.7, 3.0, 0.3}, {11.3, 3.0, 0.3}), others);
  request.fleet.max_wait_s = 5;

  Expected<FleetPlanResult> result = PlanAmongTraffic(TwoLaneSite(), request);
  ASSERT_TRUE(result) << result.error().message;
  ExpectClearOfAll(result.value().motion, others);
  EXPECT_TRUE(TakesTheNorthLane(result.value().plan.trajectory)) << "B did not take the north lane";
  EXPECT_EQ(result.value().parked_robots_avoided, 1);
  EXPECT_EQ(result.value().plan_rounds, 2)
      << "the plain route, then the route through the search's";
}

// P parked beside the way down from the north lane to B's goal. The route searched in space and
// time keeps clear of P, and the trajectory through its guides would cut the corner into P (found
// only then, it took a third plan): P is planned around from the plan through the route on.
TEST(FleetPlan, ARobotParkedOnASpaceTimeRoutesWayIsPlannedAroundFromThePlanThroughIt) {
  ExpectTheNorthLaneInTwoPlansAroundOneParkedAt({10.4, 4.4, 0.3});
}

// P parked where B's way out of the south lane runs. No waits clear A from that lane, where B
// meets A before it nears P, so going around P would clear nothing: the route is searched in
// space and time at once, around P (not after a plan around P in the south lane).
TEST(FleetPlan, ARouteThatNoWaitsClearOfMovingRobotsIsSearchedAtOnceAroundTheParkedOnes) {
  ExpectTheNorthLaneInTwoPlansAroundOneParkedAt({10.0, 1.7, 0.3});
}

// A leaves 20 s after B and drives across B's goal, where B stays parked from its arrival
// (about 5 s) to the end of its lease: no wait, stop or way round before the goal clears that.
// B arrives as planned alone and makes way there: it holds at its goal, steps aside off A's
// way before A comes, and is back once A has passed. Waiting at or beside its goal is parked
// time: B may not wait on its way (max_wait_s 0) and still does.
TEST(FleetPlan, ARobotParkedAtItsGoalMakesWayForARobotThatCrossesItLater) {
  ReservedMotion a = Committed("A", Between({0.5, 4.5, 0.3}, {5.5, 4.5, 0.3}));
  a.motion.start_ns = AddSeconds(kDeparture, 20);
  const std::vector<ReservedMotion> others = {a};
  const PlanRequest plan = Between({3, 0.5, 0.3}, {3, 4.5, 0.3});
  FleetPlanRequest request = AmongOthers(plan, others);
  request.fleet.max_wait_s = 0;
  const ReservedMotion alone = Committed("alone", plan);
  ASSERT_TRUE(SampleEveryMillisecond(alone.motion, a.motion, Limit()).conflict)
      << "parked at its goal, B would not meet A";
  Expected<FleetPlanResult> planned = PlanAmongTraffic(Site(), request);
  ASSERT_TRUE(planned) << planned.error().message;
  const FleetPlanResult& result = planned.value();
  ASSERT_TRUE(result.makes_way);
  ExpectClearOfAll(result.motion, others);
  WriteScenario("makes_way_at_goal",
                {{"B alone", &alone.motion}, {"B", &result.motion}, {"A", &a.motion}});

  // Arrives as alone, without waiting on the way, ...
  const double alone_s = alone.motion.trajectory.TotalDuration();
  EXPECT_NEAR(result.arrival_s, alone_s, 1e-6);
  const Trajectory& trajectory = result.plan.trajectory;
  const Eigen::Vector3d goal = result.plan.goal.position_m;
  EXPECT_LT((trajectory.Position(result.arrival_s).head<3>() - goal).norm(), 1e-6);
  // ... holds at its goal, leaves it before A comes, and ends there, parked.
  ASSERT_FALSE(result.holds.empty());
  EXPECT_NEAR(result.holds[0].start_s, result.arrival_s, 1e-6);
  EXPECT_LT((result.holds[0].position_m - goal).norm(), 1e-6);
  EXPECT_LT((trajectory.Position(trajectory.TotalDuration()).head<3>() - goal).norm(), 1e-6);
  // When A comes closest to the goal, B is off its way, beside it.
  const Trajectory& way = a.motion.trajectory;
  double a_closest_s = 0;
  for (double t = 0; t < way.TotalDuration(); t += 0.01) {
    if ((way.Position(t).head<2>() - goal.head<2>()).norm() <
        (way.Position(a_closest_s).head<2>() - goal.head<2>()).norm()) {
      a_closest_s = t;
    }
  }
  const double b_then_s = SecondsBetween(kDeparture, a.motion.start_ns) + a_closest_s;
  EXPECT_GT((trajectory.Position(b_then_s).head<2>() - goal.head<2>()).norm(), Limit());
  // It leaves its goal as late as it can: not long before A comes.
  EXPECT_GT(result.holds[0].duration_s, 10);
  ExpectCancelledWhereverStopped(request);
}

TEST(FleetPlan, AGoalAnotherRobotComesToStayAtIsRefusedAtOnceNamingWhoWhenAndWhere) {
  ReservedMotion a = Committed("A", Between({0.5, 4.5, 0.3}, {3, 4.5, 0.3}));
  a.motion.start_ns = AddSeconds(kDeparture, 20);
  const std::vector<ReservedMotion> others = {a};
  FleetPlanRequest request = AmongOthers(Between({3, 0.5, 0.3}, {3, 4.5, 0.3}), others);
  request.fleet.max_wait_s = 0;
  Expected<FleetPlanResult> refused = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kReservationConflict);
  EXPECT_EQ(refused.error().field, "goal.position_m");
  EXPECT_THAT(refused.error().message, HasSubstr("the goal is not free for good: robot 'A'"));
  // When A reaches B standing at its goal.
  EXPECT_THAT(refused.error().message, HasSubstr(" m, 2"));
  EXPECT_THAT(refused.error().message, HasSubstr("s after the departure"));
  EXPECT_EQ(refused.error().details.at("robot_id"), "A");
}

// The same with B routed through a point on its way: a route with vias is not searched in
// space and time, and its goal not checked before, but its waits fail only where A meets B
// parked at its goal, and B makes way there all the same.
TEST(FleetPlan, ARobotRoutedThroughViasAlsoMakesWayAtItsGoal) {
  ReservedMotion a = Committed("A", Between({0.5, 4.5, 0.3}, {5.5, 4.5, 0.3}));
  a.motion.start_ns = AddSeconds(kDeparture, 20);
  const std::vector<ReservedMotion> others = {a};
  PlanRequest plan = Between({3, 0.5, 0.3}, {3, 4.5, 0.3});
  plan.via = {Via{{3, 2.5, 0.3}, false}};
  FleetPlanRequest request = AmongOthers(plan, others);
  request.fleet.max_wait_s = 0;
  Expected<FleetPlanResult> planned = PlanAmongTraffic(Site(), request);
  ASSERT_TRUE(planned) << planned.error().message;
  EXPECT_TRUE(planned.value().makes_way);
  ExpectClearOfAll(planned.value().motion, others);
  // The request's via is passed before the arrival.
  ASSERT_EQ(planned.value().plan.via_times_s.size(), 1U);
  EXPECT_LT(planned.value().plan.via_times_s[0], planned.value().arrival_s);
  const Trajectory& trajectory = planned.value().plan.trajectory;
  EXPECT_LT((trajectory.Position(planned.value().plan.via_times_s[0]).head<3>() -
             planned.value().plan.via[0].position_m)
                .norm(),
            1e-6);
}

// A drives up the one-lane ramp, departed a second ago; B, asked for now, must come down it
// at once (it may not wait). In commit order B is refused; with A replannable, B goes first and
// A, from where it is at the notice, waits off B's way and then goes on to its goal.
TEST(FleetPlan, ARobotOnItsWayIsReplannedToLetARobotThatMayNotWaitPassFirst) {
  ReservedMotion a = Committed("A", Between({2, 4.5, 0.3}, {14.5, 4.5, 0.8}));
  a.motion.start_ns = AddSeconds(kDeparture, -1);
  const std::vector<ReservedMotion> others = {a};
  FleetPlanRequest request = AmongOthers(Between({13, 7.5, 0.8}, {2, 1.5, 0.3}), others);
  request.fleet.max_wait_s = 0;
  request.fleet.replan.max_robots = 1;
  Expected<FleetPlanResult> in_order = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(in_order) << "A not replannable: B must be refused, or the case tests nothing";
  EXPECT_EQ(in_order.error().code, ErrorCode::kReservationConflict);
  EXPECT_EQ(in_order.error().details.at("robot_id"), "A");

  const std::vector<ReplannableRobot> replannable = {{0, Profile()}};
  request.replannable = replannable;
  Expected<FleetPlanResult> b = PlanAmongTraffic(Site(), request);
  ASSERT_TRUE(b) << b.error().message;
  ASSERT_EQ(b.value().replanned.size(), 1u);
  const ReplannedRobot& replanned = b.value().replanned[0];
  EXPECT_EQ(replanned.other, 0u);
  const std::int64_t notice_ns = AddSeconds(kDeparture, request.fleet.replan.notice_s);
  EXPECT_EQ(replanned.motion.start_ns, notice_ns);
  // A's new motion takes over where its committed one is at the notice, moving as it moves.
  const double t = a.motion.TrajectoryTimeAt(notice_ns);
  EXPECT_GT(a.motion.trajectory.Velocity(t).head<2>().norm(), 0.1) << "A is on its way";
  EXPECT_LT((replanned.motion.trajectory.Position(0).head<2>() -
             a.motion.trajectory.Position(t).head<2>())
                .norm(),
            1e-6);
  EXPECT_LT((replanned.motion.trajectory.Velocity(0) - a.motion.trajectory.Velocity(t)).norm(),
            1e-6);
  // It still ends at A's goal, parked there as long as before, and waited for B on its way.
  const Trajectory& new_a = replanned.motion.trajectory;
  EXPECT_LT((new_a.Position(new_a.TotalDuration()).head<3>() -
             a.motion.trajectory.Position(a.motion.trajectory.TotalDuration()).head<3>())
                .norm(),
            1e-6);
  EXPECT_EQ(replanned.motion.end_ns, a.motion.end_ns);
  EXPECT_GT(replanned.wait_s, 0);
  // B and A as they will move: A's committed motion until the notice, then its new one.
  const FleetMotion a_then = ContinuedBy(a.motion, replanned.motion, kDeparture);
  const Sampled s = SampleEveryMillisecond(b.value().motion, a_then, Limit());
  EXPECT_FALSE(s.conflict);
  WriteScenario("replanned_on_its_way",
                {{"B", &b.value().motion}, {"A", &a_then}, {"A committed", &a.motion}});
}

TEST(FleetPlan, ReplanningOptionsAndRobotsOutOfRangeAreRefusedNamingTheField) {
  const std::vector<ReservedMotion> others = {Parked("C", {3, 2.5, 0.3})};
  FleetPlanRequest request = AmongOthers(Between({0.5, 2.5, 0.3}, {5.5, 2.5, 0.3}), others);
  request.fleet.replan.max_robots = 4;
  Expected<FleetPlanResult> refused = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().field, "fleet.replan.max_robots");
  request.fleet.replan.max_robots = 1;
  request.fleet.replan.notice_s = -1;
  refused = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().field, "fleet.replan.notice_s");
  request.fleet.replan.notice_s = 1;
  const std::vector<ReplannableRobot> beyond = {{1, Profile()}};
  request.replannable = beyond;
  refused = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(refused.error().field, "replannable[0].other");
}

// The same, with B routed through a point on its way (a route with vias is not searched in
// space and time, and its goal not checked before): refused with the first meeting, after
// the waits, stops and making way tried.
TEST(FleetPlan, AMeetingNothingClearsIsRefusedNamingWhoWhenAndWhere) {
  ReservedMotion a = Committed("A", Between({0.5, 4.5, 0.3}, {3, 4.5, 0.3}));
  a.motion.start_ns = AddSeconds(kDeparture, 20);
  const std::vector<ReservedMotion> others = {a};
  PlanRequest plan = Between({3, 0.5, 0.3}, {3, 4.5, 0.3});
  plan.via = {Via{{3, 2.5, 0.3}, false}};
  FleetPlanRequest request = AmongOthers(plan, others);
  request.fleet.max_wait_s = 0;
  Expected<FleetPlanResult> refused = PlanAmongTraffic(Site(), request);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kReservationConflict);
  EXPECT_THAT(refused.error().message, HasSubstr("the trajectory meets robot 'A'"));
  // Where B stays parked, once A reaches it.
  EXPECT_THAT(refused.error().message, HasSubstr("at (3.00, 4.50, 0.30) m, 22."));
  EXPECT_THAT(refused.error().message, HasSubstr("s after the departure"));
  EXPECT_EQ(refused.error().details.at("robot_id"), "A");
}

}  // namespace
}  // namespace strata
