// The fleet's schedule shared through a real etcd (etcd_process.hpp): two replicas, each a
// ReservationSchedule with its EtcdScheduleLedger, as two strata-server processes hold them.
// A reservation made on one is avoided on the other; two commits into one crossing at once
// let exactly one in; a replica that dies leaves its reservations to their leases; etcd down
// refuses commits with a message that says so, keeps reads, and loses nothing; a watch whose
// revision was compacted away reads afresh.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <barrier>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>
#include <set>
#include <span>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "etcd_process.hpp"
#include "server_process.hpp"
#include "shared/etcd_client.hpp"
#include "shared/etcd_schedule_ledger.hpp"
#include "test_util/trajectory_builders.hpp"

namespace strata::server {
namespace {

using ::testing::Contains;
using testing::EtcdProcess;
using testing::Eventually;
using ::testing::HasSubstr;

constexpr auto kPatience = std::chrono::seconds(20);

ScheduleLimits Limits() {
  return {.max_reservations_per_map = 100,
          .default_lease_s = 60,
          .max_lease_s = 600,
          .max_horizon_s = 3600,
          .default_separation_m = 0.1};
}

// A robot driving from `from` at `velocity` for `duration_s` from `start_ns`, then parked at
// its end until `end_ns`.
Reservation Driving(const std::string& map, const std::string& robot, std::int64_t start_ns,
                    const Eigen::Vector3d& from, const Eigen::Vector3d& velocity, double duration_s,
                    std::int64_t end_ns) {
  Reservation reservation;
  reservation.map_id = map;
  reservation.map_version = "v1";
  reservation.reserved.robot_id = robot;
  FleetMotion& motion = reservation.reserved.motion;
  motion.start_ns = start_ns;
  motion.trajectory.pieces.push_back(test_util::LinePiece(from, velocity, duration_s));
  motion.end_ns = std::max(end_ns, motion.ArrivalNs());
  return reservation;
}

// Through the origin along x, 5 s after `start_ns`; parked at (5, 0) until `lease_s` after it.
Reservation EastBound(const std::string& map, const std::string& robot, std::int64_t start_ns,
                      double lease_s = 60) {
  return Driving(map, robot, start_ns, {-5, 0, 0.3}, {1, 0, 0}, 10, AddSeconds(start_ns, lease_s));
}
// Through the origin along y at the same moment as EastBound.
Reservation NorthBound(const std::string& map, const std::string& robot, std::int64_t start_ns,
                       double lease_s = 60) {
  return Driving(map, robot, start_ns, {0, -5, 0.3}, {0, 1, 0}, 10, AddSeconds(start_ns, lease_s));
}

// One strata-server's share of the fleet's state: its schedule, fed by etcd.
struct Replica {
  explicit Replica(const std::string& endpoint, const std::string& prefix = "/strata-test",
                   const std::string& ca_file = {}) {
    EtcdOptions options;
    options.endpoints = {endpoint};
    options.ca_file = ca_file;
    options.call_timeout_s = 1;
    client = std::move(EtcdClient::Create(options)).value();
    ledger = std::make_unique<EtcdScheduleLedger>(client.get(), prefix, &schedule,
                                                  [this](bool up) { connected.store(up); });
  }
  // Whether `robot` holds a reservation on `map` here, waiting for the watch up to kPatience.
  bool Sees(const std::string& map, const std::string& robot, bool held = true) {
    const auto deadline = std::chrono::steady_clock::now() + kPatience;
    while (true) {
      const ReservationSchedule::Listing listing = schedule.List(map);
      bool found = false;
      for (const Reservation& r : listing.reservations) found |= r.reserved.robot_id == robot;
      if (found == held) return true;
      if (std::chrono::steady_clock::now() >= deadline) return false;
      schedule.WaitForChange(map, listing.revision, deadline);
    }
  }

  ReservationSchedule schedule{Limits()};
  std::unique_ptr<EtcdClient> client;
  std::atomic<bool> connected{false};
  std::unique_ptr<EtcdScheduleLedger> ledger;  // Last: stopped before the rest.
};

const Caller kAnyone{.owner = "", .admin = true};
const SeparationRule kRule{};

class SharedScheduleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    etcd_ = EtcdProcess::Start();
    ASSERT_NE(etcd_, nullptr) << "a real etcd is needed (scripts/install-deps.sh installs it)";
  }
  std::unique_ptr<EtcdProcess> etcd_;
};

TEST_F(SharedScheduleTest, AReservationCommittedOnOneReplicaIsAvoidedOnAnother) {
  Replica a(etcd_->endpoint());
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  const Result<Reservation> east =
      a.schedule.Commit(EastBound("site", "east", now), kRule, kAnyone);
  ASSERT_TRUE(east.ok()) << east.error().message;
  ASSERT_TRUE(b.Sees("site", "east"));
  const ReservationSchedule::Traffic traffic = b.schedule.OthersOf("site", "north");
  ASSERT_EQ(traffic.others.size(), 1u);
  EXPECT_EQ(traffic.others[0].robot_id, "east");
  EXPECT_EQ(traffic.revision, east.value().revision);  // One revision, etcd's, on both.

  const Result<Reservation> crossing =
      b.schedule.Commit(NorthBound("site", "north", now), kRule, kAnyone);
  ASSERT_FALSE(crossing.ok());
  EXPECT_EQ(crossing.error().code, ServiceError::Code(ErrorCode::kReservationConflict));
  EXPECT_EQ(crossing.error().metadata.at("robot_id"), "east");
  // 12 s later the crossing is clear (east parks at (5, 0), off north's way).
  const Result<Reservation> later =
      b.schedule.Commit(NorthBound("site", "north", AddSeconds(now, 12)), kRule, kAnyone);
  ASSERT_TRUE(later.ok()) << later.error().message;
  ASSERT_TRUE(a.Sees("site", "north"));
  // Released on A: gone on B, and the crossing is free on B.
  ASSERT_TRUE(a.schedule.Release("site", "east", kAnyone).ok());
  ASSERT_TRUE(b.Sees("site", "east", false));
}

// A robot that follows replans, committed on one replica, is replanned by a plan on the other:
// both reservations land in one etcd transaction, at one revision, and the first replica sees
// the replanned one with its profile and whom it was replanned for.
TEST_F(SharedScheduleTest, ARobotReplannedOnAnotherReplicaLandsTogetherWithThePlanThatMovedIt) {
  Replica a(etcd_->endpoint());
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  Reservation east = EastBound("site", "east", AddSeconds(now, 20));
  east.replan_profile = BuiltinProfile("differential").value();
  const Result<Reservation> committed = a.schedule.Commit(east, kRule, kAnyone);
  ASSERT_TRUE(committed.ok()) << committed.error().message;
  ASSERT_TRUE(b.Sees("site", "east"));
  const ReservationSchedule::Traffic traffic = b.schedule.OthersOf("site", "north");
  ASSERT_EQ(traffic.replannable.size(), 1u);
  EXPECT_EQ(traffic.replannable[0].other, 0u);
  EXPECT_EQ(traffic.replannable[0].profile.name, "differential");

  // North crosses where east would; east, replanned half a second after it leaves, stops
  // where it is then until north has passed, and goes on.
  const Reservation north = NorthBound("site", "north", AddSeconds(now, 20));
  const std::int64_t notice_ns = AddSeconds(now, 20.5);
  Reservation waiting =
      Driving("site", "east", notice_ns, {-4.5, 0, 0.3}, {0, 0, 0}, 11.5, AddSeconds(now, 80));
  waiting.reserved.motion.trajectory.pieces.push_back(
      test_util::LinePiece({-4.5, 0, 0.3}, {1, 0, 0}, 9.5));
  const std::vector<ReservedMotion> east_later = {waiting.reserved};
  const Result<std::vector<Reservation>> stale = b.schedule.CommitReplanning(
      north, east_later, committed.value().revision - 1, kRule, kAnyone);
  ASSERT_FALSE(stale.ok()) << "east changed after the revision the plan read";
  EXPECT_EQ(stale.error().code, ServiceError::Code(ErrorCode::kReservationConflict));
  const Result<std::vector<Reservation>> both =
      b.schedule.CommitReplanning(north, east_later, traffic.revision, kRule, kAnyone);
  ASSERT_TRUE(both.ok()) << both.error().message;
  ASSERT_EQ(both.value().size(), 2u);
  EXPECT_EQ(both.value()[0].revision, both.value()[1].revision);
  // Both arrive in one watch response, applied one after the other.
  ASSERT_TRUE(Eventually(
      [&] {
        const std::vector<Reservation> held = a.schedule.List("site").reservations;
        return held.size() == 2 && std::all_of(held.begin(), held.end(), [&](const Reservation& r) {
                 return r.revision == both.value()[0].revision;
               });
      },
      kPatience));
  for (const Reservation& r : a.schedule.List("site").reservations) {
    EXPECT_EQ(r.revision, both.value()[0].revision) << r.reserved.robot_id;
    if (r.reserved.robot_id != "east") continue;
    EXPECT_EQ(r.replanned_for, "north");
    ASSERT_TRUE(r.replan_profile.has_value());
    EXPECT_EQ(r.replan_profile->name, "differential");
    // Its committed motion until the notice, then the new one.
    EXPECT_EQ(r.reserved.motion.start_ns, AddSeconds(now, 20));
    EXPECT_EQ(r.reserved.motion.ArrivalNs(), waiting.reserved.motion.ArrivalNs());
  }
}

TEST_F(SharedScheduleTest, TwoCommitsIntoOneCrossingAtOnceOnTwoReplicasLetExactlyOneIn) {
  Replica a(etcd_->endpoint());
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  constexpr int kRounds = 15;
  int a_won = 0;
  int b_won = 0;
  for (int round = 0; round < kRounds; ++round) {
    // A map of its own each round: both replicas commit against a schedule they agree is
    // empty, and meet only in etcd.
    const std::string map = "crossing-" + std::to_string(round);
    std::barrier start(2);
    Result<Reservation> on_a = MakeError(ServiceErrorCode::kInternal, "not run");
    Result<Reservation> on_b = MakeError(ServiceErrorCode::kInternal, "not run");
    std::thread ta([&] {
      start.arrive_and_wait();
      on_a = a.schedule.Commit(EastBound(map, "east", now), kRule, kAnyone);
    });
    std::thread tb([&] {
      start.arrive_and_wait();
      on_b = b.schedule.Commit(NorthBound(map, "north", now), kRule, kAnyone);
    });
    ta.join();
    tb.join();
    ASSERT_NE(on_a.ok(), on_b.ok()) << "round " << round << ": exactly one commit must land ("
                                    << (on_a.ok() ? "both did" : on_a.error().message) << ")";
    const Result<Reservation>& lost = on_a.ok() ? on_b : on_a;
    EXPECT_EQ(lost.error().code, ServiceError::Code(ErrorCode::kReservationConflict))
        << lost.error().message;
    (on_a.ok() ? a_won : b_won) += 1;
    // Both replicas end up holding the winner only.
    const std::string winner = on_a.ok() ? "east" : "north";
    const std::string loser = on_a.ok() ? "north" : "east";
    for (Replica* replica : {&a, &b}) {
      ASSERT_TRUE(replica->Sees(map, winner));
      EXPECT_TRUE(replica->Sees(map, loser, false));
    }
  }
  RecordProperty("a_won", a_won);
  RecordProperty("b_won", b_won);
}

TEST_F(SharedScheduleTest, AReplicaThatDiesLeavesItsReservationsUntilTheirLeasesEnd) {
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  {
    Replica a(etcd_->endpoint());
    // Parked until 2 s after the drive ends: 12 s from now.
    const Result<Reservation> east =
        a.schedule.Commit(EastBound("site", "east", now, 12), kRule, kAnyone);
    ASSERT_TRUE(east.ok()) << east.error().message;
    ASSERT_TRUE(b.Sees("site", "east"));
  }  // A ends without releasing anything, as a replica killed with SIGKILL does.
  EXPECT_FALSE(b.schedule.Commit(NorthBound("site", "north", now), kRule, kAnyone).ok());
  // etcd keeps it until its lease ends, then removes it by itself: a fresh reader finds none.
  auto client = std::move(EtcdClient::Create({.endpoints = {etcd_->endpoint()}})).value();
  Result<etcdserverpb::RangeResponse> held = client->RangePrefix("/strata-test/schedule/site/");
  ASSERT_TRUE(held.ok());
  EXPECT_EQ(held.value().kvs_size(), 1);
  EXPECT_TRUE(Eventually(
      [&] {
        Result<etcdserverpb::RangeResponse> read =
            client->RangePrefix("/strata-test/schedule/site/");
        return read.ok() && read.value().kvs_size() == 0;
      },
      std::chrono::seconds(30)));
  EXPECT_GE(SecondsBetween(now, SystemNowNs()), 12.0) << "removed before its lease ended";
  EXPECT_TRUE(b.Sees("site", "east", false));
  const Result<Reservation> through =
      b.schedule.Commit(NorthBound("site", "north", SystemNowNs()), kRule, kAnyone);
  EXPECT_TRUE(through.ok()) << through.error().message;
}

TEST_F(SharedScheduleTest, EtcdDownRefusesChangesSayingSoKeepsReadsAndLosesNothing) {
  Replica a(etcd_->endpoint());
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  ASSERT_TRUE(a.schedule.Commit(EastBound("site", "east", now), kRule, kAnyone).ok());
  ASSERT_TRUE(b.Sees("site", "east"));

  etcd_->Kill();
  ASSERT_TRUE(Eventually([&] { return !a.connected.load(); }, kPatience));
  const Result<Reservation> refused =
      a.schedule.Commit(NorthBound("site", "north", AddSeconds(now, 12)), kRule, kAnyone);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ServiceError::Code(ServiceErrorCode::kSharedStateUnavailable));
  EXPECT_THAT(refused.error().message,
              HasSubstr("etcd at " + etcd_->endpoint() + " is unreachable"));
  // What a replica knew stays planned against.
  EXPECT_EQ(b.schedule.OthersOf("site", "north").others.size(), 1u);
  EXPECT_FALSE(a.schedule.Release("site", "east", kAnyone).ok());

  ASSERT_TRUE(etcd_->Restart());
  ASSERT_TRUE(Eventually([&] { return a.connected.load() && b.connected.load(); }, kPatience));
  const Result<Reservation> north =
      a.schedule.Commit(NorthBound("site", "north", AddSeconds(now, 12)), kRule, kAnyone);
  ASSERT_TRUE(north.ok()) << north.error().message;
  ASSERT_TRUE(b.Sees("site", "north"));
  EXPECT_TRUE(b.Sees("site", "east"));  // Nothing committed before the outage was lost.
  // And a new replica reads both from etcd.
  Replica c(etcd_->endpoint());
  EXPECT_TRUE(c.Sees("site", "east"));
  EXPECT_TRUE(c.Sees("site", "north"));
}

TEST_F(SharedScheduleTest, EtcdRestartedUnderLoadLosesNoCommitAndAdmitsNoConflict) {
  Replica a(etcd_->endpoint());
  Replica b(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  // Two writers, one per replica, committing crossing robots back and forth (each round a
  // robot of each replica through the same crossing, a second apart) until told to stop.
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::vector<std::string> landed;  // Robots whose commit returned OK.
  std::vector<std::string> refusals;
  const auto writer = [&](Replica& replica, const std::string& name, bool east) {
    for (int i = 0; !stop.load(); ++i) {
      const std::string robot = name + std::to_string(i % 40);
      const std::int64_t start = AddSeconds(now, 1.0 * (i % 40));
      const Result<Reservation> r = replica.schedule.Commit(
          east ? EastBound("site", robot, start, 20) : NorthBound("site", robot, start, 20), kRule,
          kAnyone);
      std::lock_guard lock(mutex);
      if (r.ok()) {
        landed.push_back(robot);
      } else if (r.error().code == ServiceError::Code(ServiceErrorCode::kSharedStateUnavailable)) {
        refusals.push_back(r.error().message);
      }
    }
  };
  std::thread on_a(writer, std::ref(a), "a", true);
  std::thread on_b(writer, std::ref(b), "b", false);
  const auto landed_count = [&] {
    std::lock_guard lock(mutex);
    return landed.size();
  };
  ASSERT_TRUE(Eventually([&] { return landed_count() >= 20; }, kPatience));
  etcd_->Kill();
  ASSERT_TRUE(Eventually([&] { return !refusals.empty(); }, kPatience));
  ASSERT_TRUE(etcd_->Restart());
  const std::size_t before = landed_count();
  // etcd restarted on its old data may take some seconds to elect itself again.
  EXPECT_TRUE(Eventually([&] { return landed_count() >= before + 20; }, 3 * kPatience));
  stop.store(true);
  on_a.join();
  on_b.join();
  {
    std::lock_guard lock(mutex);
    EXPECT_THAT(refusals, Contains(HasSubstr("etcd at " + etcd_->endpoint() + " is unreachable")));
  }
  // A fresh replica reads what etcd holds: every robot whose last commit landed, and no two
  // that meet.
  Replica c(etcd_->endpoint());
  ASSERT_TRUE(c.Sees("site", landed.back()));
  const ReservationSchedule::Listing held = c.schedule.List("site");
  std::set<std::string> robots;
  for (const Reservation& r : held.reservations) robots.insert(r.reserved.robot_id);
  for (const std::string& robot : landed) EXPECT_TRUE(robots.count(robot)) << robot << " lost";
  for (std::size_t i = 0; i < held.reservations.size(); ++i) {
    const std::span<const ReservedMotion> later(&held.reservations[i].reserved, 1);
    for (std::size_t j = i + 1; j < held.reservations.size(); ++j) {
      EXPECT_FALSE(FirstTrafficConflict(held.reservations[j].reserved.motion, later, kRule))
          << held.reservations[i].reserved.robot_id << " meets "
          << held.reservations[j].reserved.robot_id;
    }
  }
}

// --etcd-ca: TLS to an etcd that serves TLS only. A replica that trusts its certificate
// commits and another sees it; a plaintext one is refused, saying etcd is unreachable.
TEST(SharedScheduleTlsTest, ATrustedCertificateCommitsAndPlaintextIsRefused) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("strata-etcd-tls-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string cert = (dir / "cert.pem").string(), key = (dir / "key.pem").string();
  const std::string command =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -addext "
      "subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
      key + " -out " + cert + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "openssl could not make a certificate";
  std::unique_ptr<EtcdProcess> etcd = EtcdProcess::Start(cert, key);
  ASSERT_NE(etcd, nullptr);
  {
    Replica a(etcd->endpoint(), "/strata-test", cert);
    Replica b(etcd->endpoint(), "/strata-test", cert);
    const Result<Reservation> east =
        a.schedule.Commit(EastBound("site", "east", SystemNowNs()), kRule, kAnyone);
    ASSERT_TRUE(east.ok()) << east.error().message;
    EXPECT_TRUE(b.Sees("site", "east"));
    Replica plaintext(etcd->endpoint());
    const Result<Reservation> refused =
        plaintext.schedule.Commit(NorthBound("site", "north", SystemNowNs()), kRule, kAnyone);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ServiceError::Code(ServiceErrorCode::kSharedStateUnavailable));
  }
  etcd.reset();
  std::filesystem::remove_all(dir);
}

TEST_F(SharedScheduleTest, AWatchWhoseRevisionWasCompactedAwayReadsAfresh) {
  Replica a(etcd_->endpoint());
  const std::int64_t now = SystemNowNs();
  std::uint64_t last = 0;
  for (int i = 0; i < 3; ++i) {
    const Result<Reservation> r =
        a.schedule.Commit(EastBound("site", "east", AddSeconds(now, 40.0 * i)), kRule, kAnyone);
    ASSERT_TRUE(r.ok());
    last = r.value().revision;
  }
  ASSERT_TRUE(a.client->Compact(static_cast<std::int64_t>(last)).ok());
  // A watch from the first revision: etcd no longer has it.
  std::atomic<int> resyncs{0};
  std::atomic<std::int64_t> read_at{0};
  EtcdWatch::Handlers handlers;
  handlers.on_response = [](const etcdserverpb::WatchResponse&) {};
  handlers.resync = [&]() -> Result<std::int64_t> {
    Result<etcdserverpb::RangeResponse> read = a.client->RangePrefix("/strata-test/");
    if (!read.ok()) return std::move(read).error();
    read_at.store(read.value().header().revision());
    resyncs.fetch_add(1);
    return read.value().header().revision();
  };
  EtcdWatch watch(a.client.get(), "/strata-test/", 1, handlers);
  EXPECT_TRUE(Eventually([&] { return resyncs.load() == 1; }, kPatience));
  EXPECT_GE(read_at.load(), static_cast<std::int64_t>(last));
}

}  // namespace
}  // namespace strata::server
