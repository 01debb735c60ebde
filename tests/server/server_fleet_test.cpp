// Robots of a fleet through the real server: plans with a fleet block wait or go around the
// reservations of the others and commit their own; TrafficService reserves, renews, releases
// and lists them. Every committed pair is checked exactly by the planner's own check, from the
// reservations as the server lists them.
#include <unistd.h>

#include <filesystem>
#include <future>
#include <string>
#include <vector>

#include <gmock/gmock.h>

#include "reserved_motion.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "server_fixture.hpp"
#include "strata/fleet/traffic.hpp"
#include "strata/v1/traffic_service.grpc.pb.h"

namespace strata::server::testing {
namespace {

using ::testing::HasSubstr;

// Two diagonals across the demo's ground floor (beside the ramp, under the deck's edge), of the
// same length: two robots leaving at once meet in the middle.
constexpr double kFloorZ = 0.3;
constexpr double kDeckZ = 3.3;  // The deck over the floor's far half, which the ramp reaches.

v1::PlanRequest FleetPlan(const std::string& robot, double sx, double sy, double gx, double gy,
                          std::int64_t departure_ns, bool reserve = true) {
  v1::PlanRequest request = PlanRequestFor("demo", sx, sy, kFloorZ, gx, gy, kFloorZ);
  ToProto(departure_ns, request.mutable_departure_time());
  request.mutable_fleet()->set_robot_id(robot);
  request.mutable_fleet()->set_reserve(reserve);
  return request;
}

class ServerFleetTest : public ServerFixture {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(StartServer());
    traffic_ = v1::TrafficService::NewStub(channel_);
    // A common departure a little ahead, so that the plans' timing does not depend on how long
    // each took to make.
    departure_ns_ = AddSeconds(SystemNowNs(), 30);
  }

  v1::ListReservationsResponse List() {
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    v1::ListReservationsRequest request;
    request.set_map_id("demo");
    v1::ListReservationsResponse response;
    EXPECT_TRUE(traffic_->ListReservations(&context, request, &response).ok());
    return response;
  }

  // Releases `robot`'s reservation on the demo map.
  grpc::Status Release(const std::string& robot, v1::ReleaseReservationResponse* released) {
    v1::ReleaseReservationRequest release;
    release.set_map_id("demo");
    release.set_robot_id(robot);
    grpc::ClientContext context;
    SetDeadline(&context, 10);
    return traffic_->ReleaseReservation(&context, release, released);
  }

  // No two listed reservations meet (the planner's exact check).
  void ExpectNoTwoMeet() {
    const v1::ListReservationsResponse listed = List();
    std::vector<ReservedMotion> all;
    for (const v1::Reservation& r : listed.reservations())
      all.push_back({r.robot_id(), MotionOf(r)});
    for (std::size_t i = 0; i < all.size(); ++i) {
      const std::span<const ReservedMotion> later(all.data() + i + 1, all.size() - i - 1);
      EXPECT_FALSE(FirstTrafficConflict(all[i].motion, later, SeparationRule{}).has_value())
          << all[i].robot_id << " meets another robot";
    }
  }

  std::unique_ptr<v1::TrafficService::Stub> traffic_;
  std::int64_t departure_ns_ = 0;
};

TEST_F(ServerFleetTest, ASecondRobotIntoTheSameCrossingWaitsOrGoesAroundAndBothAreReserved) {
  v1::PlanResponse first;
  const grpc::Status a = Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &first, 120);
  ASSERT_TRUE(a.ok()) << a.error_message();
  EXPECT_EQ(first.reservation().robot_id(), "a");
  EXPECT_EQ(first.wait_s(), 0);

  // Alone (not avoiding, not reserving), the second robot's plan meets the first one.
  v1::PlanRequest alone = FleetPlan("b", 3, 10, 13, 5, departure_ns_, /*reserve=*/false);
  alone.mutable_fleet()->set_avoid_reservations(false);
  v1::PlanResponse blind;
  ASSERT_TRUE(Plan(alone, &blind, 120).ok());
  FleetMotion blind_motion = MotionOf(first.reservation());
  blind_motion.start_ns = departure_ns_;
  blind_motion.trajectory = FromProto(blind.trajectory()).value();
  blind_motion.end_ns = blind_motion.ArrivalNs();
  const std::vector<ReservedMotion> first_only = {{"a", MotionOf(first.reservation())}};
  ASSERT_TRUE(FirstTrafficConflict(blind_motion, first_only, SeparationRule{}).has_value())
      << "the scenario must make the two robots meet when the second ignores the first";

  v1::PlanResponse second;
  const grpc::Status b = Plan(FleetPlan("b", 3, 10, 13, 5, departure_ns_), &second, 120);
  ASSERT_TRUE(b.ok()) << b.error_message();
  EXPECT_EQ(second.reservation().robot_id(), "b");
  EXPECT_GT(second.reservation().revision(), first.reservation().revision());
  // Its waits are listed, each a piece at rest of its trajectory, and add up to wait_s.
  double waited_s = 0;
  const Trajectory trajectory = FromProto(second.trajectory()).value();
  for (const v1::Hold& hold : second.holds()) {
    waited_s += hold.duration_s();
    EXPECT_TRUE(trajectory.Velocity(hold.start_s() + hold.duration_s() / 2).isZero(1e-9));
  }
  EXPECT_DOUBLE_EQ(waited_s, second.wait_s());
  // It makes no way at its goal: it arrives at the trajectory's end.
  EXPECT_NEAR(second.arrival_s(), trajectory.TotalDuration(), 1e-9);
  EXPECT_EQ(List().reservations_size(), 2);
  ExpectNoTwoMeet();
}

TEST_F(ServerFleetTest, ARobotReservedWithAWideSeparationIsGivenItByTheRobotsPlannedAfterIt) {
  // The crossing above; a asks 1.5 m between bodies, b the server's default.
  v1::PlanRequest wide = FleetPlan("a", 3, 5, 13, 10, departure_ns_);
  wide.mutable_fleet()->set_separation_m(1.5);
  v1::PlanResponse first;
  const grpc::Status a = Plan(wide, &first, 120);
  ASSERT_TRUE(a.ok()) << a.error_message();
  EXPECT_EQ(first.reservation().separation_m(), 1.5);
  v1::PlanResponse second;
  const grpc::Status b = Plan(FleetPlan("b", 3, 10, 13, 5, departure_ns_), &second, 120);
  ASSERT_TRUE(b.ok()) << b.error_message();
  EXPECT_EQ(second.reservation().separation_m(), SeparationRule{}.separation_m);
  // b keeps a's 1.5 m, not only its own 0.1 m: checked with a rule of 1.5 m for both.
  SeparationRule a_asks;
  a_asks.separation_m = 1.5;
  const std::vector<ReservedMotion> first_only = {{"a", MotionOf(first.reservation())}};
  EXPECT_FALSE(
      FirstTrafficConflict(MotionOf(second.reservation()), first_only, a_asks).has_value());
  const v1::ListReservationsResponse all = List();
  for (const v1::Reservation& listed : all.reservations()) {
    EXPECT_EQ(listed.separation_m(), listed.robot_id() == "a" ? 1.5 : 0.1) << listed.robot_id();
  }
}

TEST_F(ServerFleetTest, TwoRobotsPlanningIntoOneCrossingAtOnceAreBothServedAndNeverMeet) {
  auto plan = [this](const std::string& robot, double sx, double sy, double gx, double gy) {
    auto stub = v1::PlannerService::NewStub(channel_);
    grpc::ClientContext context;
    SetDeadline(&context, 120);
    v1::PlanResponse response;
    return stub->Plan(&context, FleetPlan(robot, sx, sy, gx, gy, departure_ns_), &response);
  };
  auto a = std::async(std::launch::async, plan, "a", 3, 5, 13, 10);
  auto b = std::async(std::launch::async, plan, "b", 3, 10, 13, 5);
  const grpc::Status first = a.get(), second = b.get();
  EXPECT_TRUE(first.ok()) << first.error_message();
  EXPECT_TRUE(second.ok()) << second.error_message();
  EXPECT_EQ(List().reservations_size(), 2);
  ExpectNoTwoMeet();
}

// Robot a drives from the floor up the ramp (2.5 m wide, the only way between the floor and
// the deck); b, leaving at the same moment, comes down it, may not wait, and keeps
// kWideSeparationM from the others, so the two cannot pass on the ramp. In commit order b is
// refused; once a's reservation follows replans, b's plan replans a to let b pass first, and
// both are committed.
TEST_F(ServerFleetTest, ARobotThatFollowsReplansIsReplannedToLetAnotherPassFirst) {
  constexpr double kWideSeparationM = 2.0;
  v1::PlanRequest a = PlanRequestFor("demo", 1, 5.25, kFloorZ, 7, 9.25, kDeckZ);
  ToProto(departure_ns_, a.mutable_departure_time());
  a.mutable_fleet()->set_robot_id("a");
  a.mutable_fleet()->set_reserve(true);
  v1::PlanResponse a_planned;
  ASSERT_TRUE(Plan(a, &a_planned, 120).ok());
  v1::PlanRequest b = PlanRequestFor("demo", 10, 9.25, kDeckZ, 10, 9.5, kFloorZ);
  ToProto(departure_ns_, b.mutable_departure_time());
  b.mutable_fleet()->set_robot_id("b");
  b.mutable_fleet()->set_reserve(true);
  b.mutable_fleet()->set_max_wait_s(0);
  b.mutable_fleet()->set_separation_m(kWideSeparationM);
  b.mutable_fleet()->set_replan_robots(1);
  v1::PlanResponse b_planned;
  CallError refused = ErrorOf(Plan(b, &b_planned, 120));
  ASSERT_EQ(refused.code, grpc::StatusCode::FAILED_PRECONDITION)
      << "a does not follow replans: b must be refused, or the case tests nothing"
      << b_planned.wait_s() << " " << b_planned.arrival_s();
  EXPECT_EQ(refused.reason, "RESERVATION_CONFLICT");
  EXPECT_THAT(refused.message, HasSubstr("robot 'a'"));

  a.mutable_fleet()->set_follows_replans(true);
  ASSERT_TRUE(Plan(a, &a_planned, 120).ok());
  EXPECT_TRUE(a_planned.reservation().follows_replans());
  const grpc::Status planned = Plan(b, &b_planned, 120);
  ASSERT_TRUE(planned.ok()) << planned.error_message();
  ASSERT_EQ(b_planned.replanned_size(), 1);
  const v1::Reservation& replanned = b_planned.replanned(0);
  EXPECT_EQ(replanned.robot_id(), "a");
  EXPECT_EQ(replanned.replanned_for(), "b");
  EXPECT_TRUE(replanned.follows_replans());
  EXPECT_EQ(replanned.revision(), b_planned.reservation().revision()) << "committed together";
  // a keeps to its trajectory until a second after b's departure, then follows the new one.
  const FleetMotion before = MotionOf(a_planned.reservation());
  const FleetMotion after = MotionOf(replanned);
  const std::int64_t notice_ns = AddSeconds(departure_ns_, 1);
  EXPECT_NEAR(static_cast<double>(after.start_ns - before.start_ns), 0, 1e3);
  EXPECT_LT((after.ReferencePointAt(notice_ns) - before.ReferencePointAt(notice_ns)).norm(), 1e-6);
  EXPECT_GT(after.ArrivalNs(), before.ArrivalNs()) << "a waits for b on its way";
  const v1::ListReservationsResponse listed = List();
  ASSERT_EQ(listed.reservations_size(), 2);
  for (const v1::Reservation& r : listed.reservations()) {
    EXPECT_EQ(r.replanned_for(), r.robot_id() == "a" ? "b" : "");
  }
  // Apart by b's rule all the way (the planner's exact check).
  SeparationRule wide;
  wide.separation_m = kWideSeparationM;
  const std::vector<ReservedMotion> b_only = {{"b", MotionOf(b_planned.reservation())}};
  EXPECT_FALSE(FirstTrafficConflict(after, b_only, wide).has_value());
}

TEST_F(ServerFleetTest, ReservingATrajectoryThatMeetsAnotherIsRefusedNamingTheRobot) {
  v1::PlanResponse first;
  ASSERT_TRUE(Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &first, 120).ok());
  v1::PlanResponse blind;
  v1::PlanRequest alone = FleetPlan("b", 3, 10, 13, 5, departure_ns_, /*reserve=*/false);
  alone.mutable_fleet()->set_avoid_reservations(false);
  ASSERT_TRUE(Plan(alone, &blind, 120).ok());

  v1::ReserveTrajectoryRequest reserve;
  reserve.set_map_id("demo");
  reserve.set_robot_id("b");
  *reserve.mutable_start_time() = blind.departure_time();
  *reserve.mutable_trajectory() = blind.trajectory();
  reserve.set_profile_name("differential");
  grpc::ClientContext context;
  SetDeadline(&context, 30);
  v1::Reservation committed;
  const CallError refused = ErrorOf(traffic_->ReserveTrajectory(&context, reserve, &committed));
  EXPECT_EQ(refused.code, grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(refused.reason, "RESERVATION_CONFLICT");
  EXPECT_THAT(refused.message, HasSubstr("robot 'a'"));
  EXPECT_EQ(List().reservations_size(), 1);

  // The same trajectory a minute later is clear, and is reserved as given.
  ToProto(AddSeconds(departure_ns_, 60), reserve.mutable_start_time());
  grpc::ClientContext later;
  SetDeadline(&later, 30);
  const grpc::Status ok = traffic_->ReserveTrajectory(&later, reserve, &committed);
  ASSERT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_EQ(committed.trajectory().pieces_size(), blind.trajectory().pieces_size());
  ExpectNoTwoMeet();
}

TEST_F(ServerFleetTest, ATrajectoryToReserveIsCheckedOnTheMapAsAPlanIs) {
  v1::PlanRequest alone = FleetPlan("b", 3, 10, 13, 5, departure_ns_, /*reserve=*/false);
  v1::PlanResponse planned;
  ASSERT_TRUE(Plan(alone, &planned, 120).ok());
  // The same path a metre above the floor: nothing holds the robot up there.
  Trajectory flying = FromProto(planned.trajectory()).value();
  for (TrajectoryPiece& piece : flying.pieces) piece.coefficients(0, 2) += 1.0;

  v1::ReserveTrajectoryRequest reserve;
  reserve.set_map_id("demo");
  reserve.set_robot_id("b");
  *reserve.mutable_start_time() = planned.departure_time();
  ToProto(flying, reserve.mutable_trajectory());
  reserve.set_profile_name("differential");
  const auto refusal = [&] {
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    v1::Reservation committed;
    return ErrorOf(traffic_->ReserveTrajectory(&context, reserve, &committed));
  };
  // With a profile, verified as Plan verifies its own: the ground is a metre off.
  const CallError verified = refusal();
  EXPECT_EQ(verified.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(verified.message, HasSubstr("not safe on map demo version"));
  EXPECT_THAT(verified.fields, ::testing::Contains("trajectory"));
  // With a body alone (no limits to check), the map's rules where the body goes.
  v1::FleetBody* body = reserve.mutable_body();
  body->set_radius_m(0.3);
  body->set_reference_height_m(0.3);
  body->set_height_m(0.5);
  const CallError sampled = refusal();
  EXPECT_EQ(sampled.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(sampled.message, HasSubstr("below where the trajectory expects it"));
  EXPECT_EQ(List().reservations_size(), 0);

  // The plan itself passes both.
  *reserve.mutable_trajectory() = planned.trajectory();
  for (const bool with_body : {true, false}) {
    if (!with_body) reserve.set_profile_name("differential");
    grpc::ClientContext context;
    SetDeadline(&context, 30);
    v1::Reservation committed;
    const grpc::Status ok = traffic_->ReserveTrajectory(&context, reserve, &committed);
    ASSERT_TRUE(ok.ok()) << ok.error_message();
    EXPECT_EQ(committed.map_version(), planned.map_version());
  }
}

TEST_F(ServerFleetTest, ReservationsAreRenewedReleasedAndRefusedWhenMissing) {
  v1::PlanResponse first;
  ASSERT_TRUE(Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &first, 120).ok());
  const std::int64_t expiry = FromProto(first.reservation().expiry_time(), "").value();

  v1::RenewReservationRequest renew;
  renew.set_map_id("demo");
  renew.set_robot_id("a");
  renew.set_lease_s(600);
  v1::Reservation renewed;
  grpc::ClientContext renew_context;
  ASSERT_TRUE(traffic_->RenewReservation(&renew_context, renew, &renewed).ok());
  EXPECT_GT(FromProto(renewed.expiry_time(), "").value(), expiry);

  v1::ReleaseReservationRequest release;
  release.set_map_id("demo");
  release.set_robot_id("a");
  v1::ReleaseReservationResponse released;
  grpc::ClientContext release_context;
  ASSERT_TRUE(traffic_->ReleaseReservation(&release_context, release, &released).ok());
  EXPECT_GT(released.revision(), renewed.revision());
  EXPECT_EQ(List().reservations_size(), 0);

  grpc::ClientContext again;
  const CallError missing = ErrorOf(traffic_->ReleaseReservation(&again, release, &released));
  EXPECT_EQ(missing.code, grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(missing.reason, "RESERVATION_NOT_FOUND");

  release.set_map_id("no_such_map");
  grpc::ClientContext unknown;
  EXPECT_EQ(ErrorOf(traffic_->ReleaseReservation(&unknown, release, &released)).reason,
            "MAP_NOT_FOUND");
}

TEST_F(ServerFleetTest, ALateRobotReportsItAndLearnsWhomItNowMeets) {
  // b crosses a's way 30 s after a: clear. Then a reports 30 s late: now they meet.
  v1::PlanResponse first, second;
  ASSERT_TRUE(Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &first, 120).ok());
  ASSERT_TRUE(Plan(FleetPlan("b", 3, 10, 13, 5, AddSeconds(departure_ns_, 30)), &second, 120).ok());
  EXPECT_EQ(second.wait_s(), 0);
  v1::ReportProgressRequest late;
  late.set_map_id("demo");
  late.set_robot_id("a");
  late.set_delay_s(30);
  v1::ReportProgressResponse moved;
  grpc::ClientContext context;
  const grpc::Status reported = traffic_->ReportProgress(&context, late, &moved);
  ASSERT_TRUE(reported.ok()) << reported.error_message();
  EXPECT_EQ(FromProto(moved.reservation().start_time(), "").value(), AddSeconds(departure_ns_, 30));
  ASSERT_EQ(moved.meetings_size(), 1);
  EXPECT_EQ(moved.meetings(0).robot_id(), "b");
  const std::int64_t when = FromProto(moved.meetings(0).time(), "").value();
  EXPECT_GT(when, AddSeconds(departure_ns_, 30));
  // The list holds the late reservation: the two now meet, as the answer said.
  v1::ListReservationsResponse listed = List();
  EXPECT_EQ(listed.separation_m(), SeparationRule{}.separation_m);
  std::vector<ReservedMotion> all;
  for (const v1::Reservation& r : listed.reservations()) all.push_back({r.robot_id(), MotionOf(r)});
  ASSERT_EQ(all.size(), 2u);
  EXPECT_TRUE(FirstTrafficConflict(all[0].motion, std::span(&all[1], 1), SeparationRule{}));
}

TEST_F(ServerFleetTest, AWatchSeesEachReservationMadeAndReleasedAndEndsWithItsMap) {
  grpc::ClientContext context;
  SetDeadline(&context, 120);
  v1::WatchScheduleRequest watch;
  watch.set_map_id("demo");
  auto stream = traffic_->WatchSchedule(&context, watch);
  v1::PlanResponse first;
  ASSERT_TRUE(Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &first, 120).ok());
  v1::ScheduleChange change;
  ASSERT_TRUE(stream->Read(&change));
  EXPECT_EQ(change.kind(), v1::ScheduleChange::RESERVED);
  EXPECT_EQ(change.robot_id(), "a");
  EXPECT_EQ(change.reservation().revision(), first.reservation().revision());
  EXPECT_EQ(change.reservation().trajectory().pieces_size(), first.trajectory().pieces_size());

  v1::ReleaseReservationResponse released;
  ASSERT_TRUE(Release("a", &released).ok());
  ASSERT_TRUE(stream->Read(&change));
  EXPECT_EQ(change.kind(), v1::ScheduleChange::RELEASED);
  EXPECT_EQ(change.robot_id(), "a");
  EXPECT_EQ(change.revision(), released.revision());

  // The map goes, and the watch with it.
  grpc::ClientContext delete_context;
  v1::DeleteMapRequest remove;
  remove.set_map_id("demo");
  v1::DeleteMapResponse removed;
  ASSERT_TRUE(maps_->DeleteMap(&delete_context, remove, &removed).ok());
  while (stream->Read(&change)) {
  }
  const CallError ended = ErrorOf(stream->Finish());
  EXPECT_EQ(ended.code, grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(ended.reason, "MAP_NOT_FOUND");
}

// With a map store the map can change under reservations: a watch says which robot must plan
// again, where and why, and leaves the others alone.
class ServerFleetMapChangeTest : public ServerFleetTest {
 protected:
  void SetUp() override {
    store_ = std::filesystem::path(::testing::TempDir()) /
             ("server_fleet_store." + std::to_string(::getpid()));
    std::filesystem::remove_all(store_);
    ASSERT_NO_FATAL_FAILURE(StartServer({"--map-store", store_.string()}));
    traffic_ = v1::TrafficService::NewStub(channel_);
    departure_ns_ = AddSeconds(SystemNowNs(), 30);
  }
  void TearDown() override {
    ServerFleetTest::TearDown();
    server_.reset();
    std::filesystem::remove_all(store_);
  }
  std::filesystem::path store_;
};

TEST_F(ServerFleetMapChangeTest, AKeepOutZoneOverARobotsGoalTellsItToPlanAgain) {
  grpc::ClientContext context;
  SetDeadline(&context, 120);
  v1::WatchScheduleRequest watch;
  watch.set_map_id("demo");
  auto stream = traffic_->WatchSchedule(&context, watch);
  v1::PlanResponse a, b;
  ASSERT_TRUE(Plan(FleetPlan("a", 3, 5, 13, 10, departure_ns_), &a, 120).ok());
  ASSERT_TRUE(Plan(FleetPlan("b", 3, 10, 13, 5, departure_ns_), &b, 120).ok());
  v1::ScheduleChange change;
  for (const char* robot : {"a", "b"}) {
    ASSERT_TRUE(stream->Read(&change));
    EXPECT_EQ(change.kind(), v1::ScheduleChange::RESERVED);
    EXPECT_EQ(change.robot_id(), robot);
  }

  // An aisle closed over a's goal, where it parks.
  v1::UpdateMapRequest update;
  update.set_map_id("demo");
  SetBox(update.add_edits()->mutable_add_keep_out(), 12.5, 9.5, 13.5, 10.5, -1, 3);
  v1::UpdateMapResponse updated;
  grpc::ClientContext update_context;
  SetDeadline(&update_context, 60);
  const grpc::Status status = maps_->UpdateMap(&update_context, update, &updated);
  ASSERT_TRUE(status.ok()) << status.error_message();

  ASSERT_TRUE(stream->Read(&change));
  EXPECT_EQ(change.kind(), v1::ScheduleChange::REPLAN_NEEDED);
  EXPECT_EQ(change.robot_id(), "a");
  EXPECT_EQ(change.reservation().revision(), a.reservation().revision());
  EXPECT_EQ(change.replan().map_version(), updated.map().version());
  EXPECT_THAT(change.replan().reason(), HasSubstr("keep-out zone"));
  EXPECT_NEAR(change.replan().position_m().x(), 13, 1.0);
  EXPECT_NEAR(change.replan().position_m().y(), 10, 1.0);
  const std::int64_t when = FromProto(change.replan().time(), "time").value();
  EXPECT_GE(when, departure_ns_);
  EXPECT_LE(when, MotionOf(a.reservation()).end_ns);

  // b was checked in the same pass and is safe: a's release is the next change.
  v1::ReleaseReservationResponse released;
  ASSERT_TRUE(Release("a", &released).ok());
  ASSERT_TRUE(stream->Read(&change));
  EXPECT_EQ(change.kind(), v1::ScheduleChange::RELEASED);
  EXPECT_EQ(change.robot_id(), "a");
  context.TryCancel();
}

TEST_F(ServerFleetTest, BadFleetRequestsNameTheFieldToFix) {
  v1::PlanRequest no_robot = FleetPlan("", 3, 5, 13, 10, departure_ns_);
  v1::PlanResponse response;
  CallError error = ErrorOf(Plan(no_robot, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ::testing::Contains("fleet.robot_id"));

  v1::PlanRequest waits_too_long = FleetPlan("a", 3, 5, 13, 10, departure_ns_);
  waits_too_long.mutable_fleet()->set_max_wait_s(7200);
  error = ErrorOf(Plan(waits_too_long, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ::testing::Contains("fleet.max_wait_s"));

  v1::PlanRequest far_ahead = FleetPlan("a", 3, 5, 13, 10, AddSeconds(departure_ns_, 86400));
  error = ErrorOf(Plan(far_ahead, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.message, HasSubstr("--max-reservation-horizon-s"));

  for (const char* field : {"fleet.follows_replans", "fleet.replan_robots"}) {
    v1::PlanRequest unreserved = FleetPlan("a", 3, 5, 13, 10, departure_ns_, /*reserve=*/false);
    if (std::string(field) == "fleet.follows_replans") {
      unreserved.mutable_fleet()->set_follows_replans(true);
    } else {
      unreserved.mutable_fleet()->set_replan_robots(1);
    }
    error = ErrorOf(Plan(unreserved, &response));
    EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(error.fields, ::testing::Contains(field));
    EXPECT_THAT(error.message, HasSubstr("set fleet.reserve too"));
  }
  v1::PlanRequest too_many = FleetPlan("a", 3, 5, 13, 10, departure_ns_);
  too_many.mutable_fleet()->set_replan_robots(4);
  error = ErrorOf(Plan(too_many, &response));
  EXPECT_EQ(error.code, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(error.fields, ::testing::Contains("fleet.replan_robots"));

  v1::PlanRequest departure_alone = PlanRequestFor("demo", 3, 5, kFloorZ, 13, 10, kFloorZ);
  ToProto(departure_ns_, departure_alone.mutable_departure_time());
  error = ErrorOf(Plan(departure_alone, &response));
  EXPECT_THAT(error.fields, ::testing::Contains("departure_time"));
  EXPECT_EQ(List().reservations_size(), 0);
}

}  // namespace
}  // namespace strata::server::testing
