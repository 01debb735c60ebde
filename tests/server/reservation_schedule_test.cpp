// The reservations of the robots on each map: commits checked exactly against the others,
// a robot's own replaced, leases renewed and collected, owners, limits, and concurrent
// commits of which exactly the compatible ones land.
#include "traffic/reservation_schedule.hpp"

#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util/trajectory_builders.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kEpoch = 1'795'000'000 * kSecond;  // A date in 2026.

ScheduleLimits Limits() {
  return {.max_reservations_per_map = 8,
          .default_lease_s = 60,
          .max_lease_s = 600,
          .max_horizon_s = 3600,
          .default_separation_m = 0.1};
}

// A robot driving from `from` at `velocity` for `duration_s` from `start_ns`, then parked at
// its end until `end_ns`: one reservation on map "site".
Reservation Driving(const std::string& robot, std::int64_t start_ns, const Eigen::Vector3d& from,
                    const Eigen::Vector3d& velocity, double duration_s, std::int64_t end_ns) {
  Reservation reservation;
  reservation.map_id = "site";
  reservation.map_version = "v1";
  reservation.reserved.robot_id = robot;
  FleetMotion& motion = reservation.reserved.motion;
  motion.start_ns = start_ns;
  motion.trajectory.pieces.push_back(test_util::LinePiece(from, velocity, duration_s));
  motion.end_ns = std::max(end_ns, motion.ArrivalNs());
  return reservation;
}

// Along x through the origin, reaching it 5 s after kEpoch + delay_s, parked 20 s after.
Reservation EastBound(const std::string& robot, double delay_s = 0) {
  const std::int64_t start = AddSeconds(kEpoch, delay_s);
  return Driving(robot, start, {-5, 0, 0.3}, {1, 0, 0}, 10, AddSeconds(start, 30));
}
// Along y through the origin at the same moment as EastBound.
Reservation NorthBound(const std::string& robot, double delay_s = 0) {
  const std::int64_t start = AddSeconds(kEpoch, delay_s);
  return Driving(robot, start, {0, -5, 0.3}, {0, 1, 0}, 10, AddSeconds(start, 30));
}

bool HasCode(const ServiceError& error, ServiceError::Code code) { return error.code == code; }

class ReservationScheduleTest : public ::testing::Test {
 protected:
  std::atomic<std::int64_t> now_{kEpoch};
  ReservationSchedule schedule_{Limits(), [this] { return now_.load(); }};
  const SeparationRule rule_{};
  const Caller anyone_{.owner = "", .admin = true};
};

TEST_F(ReservationScheduleTest, ACommitThatMeetsAnotherRobotIsRefusedNamingIt) {
  ASSERT_TRUE(schedule_.Commit(EastBound("east"), rule_, anyone_).ok());
  const Result<Reservation> crossing = schedule_.Commit(NorthBound("north"), rule_, anyone_);
  ASSERT_FALSE(crossing.ok());
  EXPECT_TRUE(HasCode(crossing.error(), ErrorCode::kReservationConflict));
  EXPECT_EQ(crossing.error().metadata.at("robot_id"), "east");
  EXPECT_THAT(crossing.error().message, HasSubstr("east"));
  // 12 s later the crossing is clear (east is parked at (5, 0), off north's path x = 0): it
  // commits, at the next revision.
  const Result<Reservation> later = schedule_.Commit(NorthBound("north", 12), rule_, anyone_);
  ASSERT_TRUE(later.ok()) << later.error().message;
  EXPECT_EQ(later.value().revision, 2u);
  EXPECT_EQ(schedule_.List("site").reservations.size(), 2u);
}

TEST_F(ReservationScheduleTest, ARobotsNewReservationReplacesItsOwnAndNeverMeetsIt) {
  ASSERT_TRUE(schedule_.Commit(EastBound("r1"), rule_, anyone_).ok());
  const Result<Reservation> again = schedule_.Commit(NorthBound("r1"), rule_, anyone_);
  ASSERT_TRUE(again.ok()) << again.error().message;
  const ReservationSchedule::Listing listing = schedule_.List("site");
  ASSERT_EQ(listing.reservations.size(), 1u);
  EXPECT_EQ(listing.reservations[0].reserved.motion.trajectory.pieces[0].coefficients(1, 1), 1.0);
  EXPECT_TRUE(schedule_.OthersOf("site", "r1").others.empty());
  EXPECT_EQ(schedule_.OthersOf("site", "r2").others.size(), 1u);
}

TEST_F(ReservationScheduleTest, ANewReservationDepartingLaterKeepsTheRobotOnItsOldOneUntilThen) {
  // r1 drives east through the origin (from (-5, 0) at +0 s to (5, 0) at +10 s); at +2 s it
  // commits a new plan that leaves where it will be at +8 s, (3, 0), northwards.
  ASSERT_TRUE(schedule_.Commit(EastBound("r1"), rule_, anyone_).ok());
  now_ = AddSeconds(kEpoch, 2);
  const std::int64_t departure = AddSeconds(kEpoch, 8);
  const Result<Reservation> turned = schedule_.Commit(
      Driving("r1", departure, {3, 0, 0.3}, {0, 1, 0}, 5, AddSeconds(kEpoch, 40)), rule_, anyone_);
  ASSERT_TRUE(turned.ok()) << turned.error().message;
  const FleetMotion& motion = turned.value().reserved.motion;
  EXPECT_EQ(motion.start_ns, kEpoch);  // Its one piece ends after now: kept, cut at +8 s.
  EXPECT_TRUE(motion.ReferencePointAt(AddSeconds(kEpoch, 5)).isApprox(Eigen::Vector3d(0, 0, 0.3)));
  EXPECT_TRUE(motion.ReferencePointAt(AddSeconds(kEpoch, 10)).isApprox(Eigen::Vector3d(3, 2, 0.3)));

  // Until +8 s r1 still drives through the origin: a robot crossing it at +5 s meets r1 ...
  const Result<Reservation> crossing = schedule_.Commit(NorthBound("r2"), rule_, anyone_);
  ASSERT_FALSE(crossing.ok());
  EXPECT_EQ(crossing.error().metadata.at("robot_id"), "r1");
  // ... and one crossing the old way at +10 s, when r1 would have been there, does not.
  const Result<Reservation> behind = schedule_.Commit(
      Driving("r2", AddSeconds(kEpoch, 9), {4.5, -1, 0.3}, {0, 1, 0}, 2, AddSeconds(kEpoch, 12)),
      rule_, anyone_);
  EXPECT_TRUE(behind.ok()) << behind.error().message;
}

TEST_F(ReservationScheduleTest, ExpiredLeasesAreCollectedAndMoveTheRevision) {
  ASSERT_TRUE(schedule_.Commit(EastBound("r1"), rule_, anyone_).ok());  // Held until +30 s.
  now_ = AddSeconds(kEpoch, 29);
  EXPECT_EQ(schedule_.List("site").reservations.size(), 1u);
  EXPECT_EQ(schedule_.collected(), 0u);
  now_ = AddSeconds(kEpoch, 31);
  const ReservationSchedule::Listing listing = schedule_.List("site");
  EXPECT_TRUE(listing.reservations.empty());
  EXPECT_EQ(listing.revision, 2u);
  EXPECT_EQ(schedule_.collected(), 1u);
  // What expired is in nobody's way.
  EXPECT_TRUE(schedule_.Commit(NorthBound("r2"), rule_, anyone_).ok());
}

TEST_F(ReservationScheduleTest, TheLimitPerMapRefusesAnotherRobotButNotAReplacement) {
  for (int i = 0; i < Limits().max_reservations_per_map; ++i) {
    ASSERT_TRUE(
        schedule_.Commit(EastBound("r" + std::to_string(i), 40.0 * i), rule_, anyone_).ok());
  }
  const Result<Reservation> one_more = schedule_.Commit(EastBound("extra", 1000), rule_, anyone_);
  ASSERT_FALSE(one_more.ok());
  EXPECT_TRUE(HasCode(one_more.error(), ErrorCode::kResourceExhausted));
  EXPECT_THAT(one_more.error().message, HasSubstr("8 reservations"));
  EXPECT_THAT(one_more.error().message, HasSubstr("--max-reservations"));
  EXPECT_TRUE(schedule_.Commit(EastBound("r0", 2000), rule_, anyone_).ok());
  // Another map has its own room.
  Reservation elsewhere = EastBound("extra");
  elsewhere.map_id = "other";
  EXPECT_TRUE(schedule_.Commit(elsewhere, rule_, anyone_).ok());
}

TEST_F(ReservationScheduleTest, OnlyItsOwnerOrAnAdminChangesAReservation) {
  const Caller alice{.owner = "alice", .admin = false};
  const Caller bob{.owner = "bob", .admin = false};
  const Caller admin{.owner = "root", .admin = true};
  ASSERT_TRUE(schedule_.Commit(EastBound("r1"), rule_, alice).ok());
  for (const ServiceError& denied : {schedule_.Commit(NorthBound("r1"), rule_, bob).error(),
                                     schedule_.Release("site", "r1", bob).error(),
                                     schedule_.Renew("site", "r1", 100, rule_, bob).error()}) {
    EXPECT_TRUE(HasCode(denied, ServiceErrorCode::kPermissionDenied)) << denied.message;
    EXPECT_THAT(denied.message, HasSubstr("r1"));
  }
  EXPECT_TRUE(schedule_.Renew("site", "r1", 100, rule_, alice).ok());
  EXPECT_TRUE(schedule_.Release("site", "r1", admin).ok());
  const Result<std::uint64_t> gone = schedule_.Release("site", "r1", alice);
  ASSERT_FALSE(gone.ok());
  EXPECT_TRUE(HasCode(gone.error(), ServiceErrorCode::kReservationNotFound));
}

TEST_F(ReservationScheduleTest, RenewingChecksTheLongerStayAndKeepsTheLeaseWhenItMeetsSomeone) {
  // r1 arrives at (5, 0) 10 s in and holds it until 30 s; r2 drives through (5, 0) along y,
  // there at 45 s.
  ASSERT_TRUE(schedule_.Commit(EastBound("r1"), rule_, anyone_).ok());
  ASSERT_TRUE(schedule_
                  .Commit(Driving("r2", AddSeconds(kEpoch, 40), {5, -5, 0.3}, {0, 1, 0}, 10,
                                  AddSeconds(kEpoch, 50)),
                          rule_, anyone_)
                  .ok());
  const Result<Reservation> too_long = schedule_.Renew("site", "r1", 60, rule_, anyone_);
  ASSERT_FALSE(too_long.ok());
  EXPECT_TRUE(HasCode(too_long.error(), ErrorCode::kReservationConflict));
  EXPECT_EQ(too_long.error().metadata.at("robot_id"), "r2");
  for (const Reservation& r : schedule_.List("site").reservations) {
    if (r.reserved.robot_id == "r1") EXPECT_EQ(r.reserved.motion.end_ns, AddSeconds(kEpoch, 30));
  }
  const Result<Reservation> short_enough = schedule_.Renew("site", "r1", 35, rule_, anyone_);
  ASSERT_TRUE(short_enough.ok()) << short_enough.error().message;
  EXPECT_EQ(short_enough.value().reserved.motion.end_ns, AddSeconds(kEpoch, 35));
  // A renewal never shortens the lease.
  EXPECT_EQ(schedule_.Renew("site", "r1", 1, rule_, anyone_).value().reserved.motion.end_ns,
            AddSeconds(kEpoch, 35));
}

TEST_F(ReservationScheduleTest, RequestsOutsideTheBoundsAreRefusedWithTheBound) {
  EXPECT_TRUE(schedule_.CheckRequest("r1", "robot_id", kEpoch, 60).ok());
  for (const std::string& bad : {std::string(), std::string("two words"), std::string(129, 'x')}) {
    const ServiceStatus refused = schedule_.CheckRequest(bad, "fleet.robot_id", kEpoch, 60);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().field_violations.at(0).field, "fleet.robot_id");
  }
  const ServiceStatus far = schedule_.CheckRequest("r1", "robot_id", AddSeconds(kEpoch, 4000), 60);
  ASSERT_FALSE(far.ok());
  EXPECT_THAT(far.error().message, HasSubstr("--max-reservation-horizon-s"));
  const ServiceStatus long_lease = schedule_.CheckRequest("r1", "robot_id", kEpoch, 601);
  ASSERT_FALSE(long_lease.ok());
  EXPECT_THAT(long_lease.error().message, HasSubstr("--max-lease-s"));
}

TEST_F(ReservationScheduleTest, ListingTakesATimeWindowAndADeletedMapTakesItsReservations) {
  ASSERT_TRUE(schedule_.Commit(EastBound("early"), rule_, anyone_).ok());      // 0 to 30 s.
  ASSERT_TRUE(schedule_.Commit(EastBound("late", 100), rule_, anyone_).ok());  // 100 to 130 s.
  const auto window = schedule_.List("site", AddSeconds(kEpoch, 40), AddSeconds(kEpoch, 200));
  ASSERT_EQ(window.reservations.size(), 1u);
  EXPECT_EQ(window.reservations[0].reserved.robot_id, "late");
  schedule_.DropMap("site");
  EXPECT_TRUE(schedule_.List("site").reservations.empty());
  EXPECT_EQ(schedule_.size(), 0u);
}

TEST_F(ReservationScheduleTest, ALateRobotMovesItsReservationAndIsToldWhomItNowMeets) {
  // North crosses the origin 12 s after east: clear. East reports 12 s late: now they meet.
  ASSERT_TRUE(schedule_.Commit(EastBound("east"), rule_, anyone_).ok());
  ASSERT_TRUE(schedule_.Commit(NorthBound("north", 12), rule_, anyone_).ok());
  const Result<ReservationSchedule::Moved> late = schedule_.Shift("site", "east", 12, anyone_);
  ASSERT_TRUE(late.ok()) << late.error().message;
  EXPECT_EQ(late.value().reservation.reserved.motion.start_ns, AddSeconds(kEpoch, 12));
  EXPECT_EQ(late.value().reservation.reserved.motion.end_ns, AddSeconds(kEpoch, 42));
  ASSERT_EQ(late.value().meetings.size(), 1u);
  EXPECT_EQ(late.value().meetings[0].robot_id, "north");
  // Both at the origin 17 s in, each at 1 m/s at right angles: within 0.7 m from 0.7/√2 s before.
  EXPECT_NEAR(SecondsBetween(kEpoch, late.value().meetings[0].conflict.time_ns),
              17 - 0.7 / std::sqrt(2.0), 0.01);
  // The move is committed: the schedule holds the late reservation.
  for (const Reservation& r : schedule_.List("site").reservations) {
    if (r.reserved.robot_id == "east")
      EXPECT_EQ(r.reserved.motion.start_ns, AddSeconds(kEpoch, 12));
  }
  // Back on time: no meeting.
  EXPECT_TRUE(schedule_.Shift("site", "east", -12, anyone_).value().meetings.empty());
  EXPECT_FALSE(schedule_.Shift("site", "east", std::nan(""), anyone_).ok());
  EXPECT_FALSE(schedule_.Shift("site", "ghost", 1, anyone_).ok());
}

TEST_F(ReservationScheduleTest, ARobotThatAsksMoreSeparationIsGivenItByTheRobotsAfterIt) {
  // East asks for 1 m between bodies; north, planned after it with the default 0.1 m, crossing
  // the origin 1 s after east passes 1.41 m from it: clear of 0.6 m of radii plus 0.1 m, not of
  // plus east's 1 m, so it is refused. 3 s after, it passes 2.12 m from east and commits.
  SeparationRule wide = rule_;
  wide.separation_m = 1.0;
  ASSERT_TRUE(schedule_.Commit(EastBound("east"), wide, anyone_).ok());
  const Result<Reservation> close = schedule_.Commit(NorthBound("north", 1), rule_, anyone_);
  ASSERT_FALSE(close.ok());
  EXPECT_TRUE(HasCode(close.error(), ErrorCode::kReservationConflict));
  EXPECT_THAT(close.error().message, HasSubstr("need 1.600 m"));
  ASSERT_TRUE(schedule_.Commit(NorthBound("north", 3), rule_, anyone_).ok());
  for (const Reservation& r : schedule_.List("site").reservations) {
    EXPECT_EQ(r.reserved.motion.separation_m,
              r.reserved.robot_id == "east" ? 1.0 : rule_.separation_m);
  }
  // A renewal asks its own separation from then on.
  SeparationRule none = rule_;
  none.separation_m = 0;
  const Result<Reservation> renewed = schedule_.Renew("site", "north", 100, none, anyone_);
  ASSERT_TRUE(renewed.ok()) << renewed.error().message;
  EXPECT_EQ(renewed.value().reserved.motion.separation_m, 0.0);
  // East 1 s late: 1.41 m from north again (east still asks 1 m), so the move names north.
  const Result<ReservationSchedule::Moved> late = schedule_.Shift("site", "east", 1, anyone_);
  ASSERT_TRUE(late.ok()) << late.error().message;
  ASSERT_EQ(late.value().meetings.size(), 1u);
  EXPECT_EQ(late.value().meetings[0].robot_id, "north");
  EXPECT_NEAR(late.value().meetings[0].conflict.limit_m, 1.6, 1e-9);
}

// Robots racing into the same crossing at the same moment: exactly one commits; the schedule
// never holds two motions that meet.
TEST_F(ReservationScheduleTest, OfRobotsCommittingIntoOneCrossingAtOnceExactlyOneLands) {
  constexpr int kRobots = 6;
  std::atomic<int> committed{0}, refused{0};
  std::vector<std::thread> robots;
  for (int i = 0; i < kRobots; ++i) {
    robots.emplace_back([&, i] {
      const double angle = 3.14159265358979 * i / kRobots;
      const Eigen::Vector3d velocity(std::cos(angle), std::sin(angle), 0);
      Reservation r =
          Driving("r" + std::to_string(i), kEpoch, Eigen::Vector3d(0, 0, 0.3) - 5 * velocity,
                  velocity, 10, AddSeconds(kEpoch, 30));
      const Result<Reservation> outcome = schedule_.Commit(std::move(r), rule_, anyone_);
      (outcome.ok() ? committed : refused)++;
      if (!outcome.ok()) {
        EXPECT_TRUE(HasCode(outcome.error(), ErrorCode::kReservationConflict));
      }
    });
  }
  for (std::thread& robot : robots) robot.join();
  EXPECT_EQ(committed.load(), 1);
  EXPECT_EQ(refused.load(), kRobots - 1);
  EXPECT_EQ(schedule_.List("site").reservations.size(), 1u);
}

}  // namespace
}  // namespace strata::server
