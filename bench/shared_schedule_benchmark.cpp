// The fleet's schedule shared through etcd (--etcd), measured for docs/benchmarks.md: two
// replicas in this process, each a ReservationSchedule with its own EtcdClient (its own
// connection) and EtcdScheduleLedger, as two strata-server processes hold them. Not part of
// the test path; bench/with_etcd.sh starts a throwaway etcd and runs it.
//
//   build/bench/shared_schedule_benchmark --etcd 127.0.0.1:2379 [--commits 500]
//       [--robots 40] [--seconds 60] [--speedup 10] [--seed 1]
//
// 1. Commits: --commits reservations committed on replica A one after another (robots parked
//    apart, so none conflicts): the commit's latency through etcd, next to the same commits
//    in a schedule without a ledger; and how long after A's commit returned replica B's
//    schedule holds it (the watch's propagation delay).
// 2. A fleet through the replicas: --robots differential robots on the parking garage, each
//    replica planning for its half (a thread each) as the server's Plan does with reserve:
//    PlanAmongTraffic on the replica's schedule, then Commit, replanned when another commit
//    got in first. Robots get their next task on arrival. The robots' clock runs --speedup
//    times faster than the wall's, so that the replicas are saturated: plans per second with
//    2 replicas against 1 is the capacity gained. Every committed motion is then checked in
//    pairs by the benchmark's own 1 ms sampled check (oracle/sampled_separation.hpp).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "common/log.hpp"
#include "fleet_site.hpp"
#include "sampled_separation.hpp"
#include "shared/etcd_client.hpp"
#include "shared/etcd_schedule_ledger.hpp"
#include "statistics.hpp"
#include "strata/fleet/fleet_plan.hpp"
#include "strata/scenes/scenes.hpp"

namespace {

using strata::AddSeconds;
using strata::FleetMotion;
using strata::bench::Median;
using strata::bench::Quantile;
using strata::server::Caller;
using strata::server::EtcdClient;
using strata::server::EtcdOptions;
using strata::server::EtcdScheduleLedger;
using strata::server::Reservation;
using strata::server::ReservationSchedule;
using strata::server::ScheduleLimits;
using Clock = std::chrono::steady_clock;

constexpr double kMinTaskLengthM = 3.0;
constexpr double kMinGoalDistanceM = 1.5;  // From every other robot's position.
constexpr double kParkedLeaseS = 600;      // Robots stay parked until their next plan.
constexpr double kRetryAfterS = 5.0;       // A refused robot tries again after [s, robots'].
constexpr int kMaxCommitAttempts = 3;      // As the server's Plan with reserve.
constexpr double kHorizontalSpeedSlack = 1.01;
const Caller kCaller{.owner = "", .admin = true};

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

ScheduleLimits Limits() {
  return {.max_reservations_per_map = 100000,
          .default_lease_s = 60,
          .max_lease_s = 3600,
          .max_horizon_s = 3600,
          .default_separation_m = strata::SeparationRule{}.separation_m};
}

// One strata-server's share: its own connection to etcd, its ledger, its schedule.
struct Replica {
  Replica(const std::string& endpoint, const std::string& prefix,
          std::function<std::int64_t()> now_ns)
      : schedule(Limits(), std::move(now_ns)) {
    EtcdOptions options;
    options.endpoints = {endpoint};
    client = std::move(EtcdClient::Create(options)).value();
    ledger = std::make_unique<EtcdScheduleLedger>(client.get(), prefix, &schedule, nullptr);
  }
  ReservationSchedule schedule;
  std::unique_ptr<EtcdClient> client;
  std::unique_ptr<EtcdScheduleLedger> ledger;
};

Reservation Parked(const std::string& map, const std::string& robot, const Eigen::Vector3d& at,
                   std::int64_t from_ns, double lease_s, const strata::FleetBody& body) {
  Reservation reservation;
  reservation.map_id = map;
  reservation.reserved.robot_id = robot;
  FleetMotion& motion = reservation.reserved.motion;
  motion.start_ns = from_ns;
  strata::TrajectoryPiece stand;
  stand.duration_s = 0.1;
  stand.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
  stand.coefficients.row(0) = at.transpose();
  motion.trajectory.pieces.push_back(stand);
  motion.body = body;
  motion.end_ns = AddSeconds(from_ns, lease_s);
  return reservation;
}

void MeasureCommits(const std::string& endpoint, int commits) {
  const strata::FleetBody body;
  std::vector<double> shared_ms, memory_ms, propagation_ms;
  Replica a(endpoint, "/strata-bench", strata::server::SystemNowNs);
  Replica b(endpoint, "/strata-bench", strata::server::SystemNowNs);
  ReservationSchedule alone(Limits());
  const std::string map = fmt::format("commits-{}", strata::server::SystemNowNs());
  for (int i = 0; i < commits; ++i) {
    // 50 robots 2 m apart, each committed again and again.
    const Reservation r = Parked(map, fmt::format("r{}", i % 50), {2.0 * (i % 50), 0, 0.3},
                                 strata::server::SystemNowNs(), 60, body);
    const auto t0 = Clock::now();
    auto committed = a.schedule.Commit(r, {}, kCaller);
    const auto t1 = Clock::now();
    if (!committed.ok()) {
      std::fprintf(stderr, "commit failed: %s\n", committed.error().message.c_str());
      return;
    }
    shared_ms.push_back(Ms(t1 - t0));
    // B holds it once its map's revision reaches the commit's.
    std::uint64_t seen = b.schedule.List(map).revision;
    while (seen < committed.value().revision) {
      seen = b.schedule.WaitForChange(map, seen, Clock::now() + std::chrono::seconds(10));
    }
    propagation_ms.push_back(Ms(Clock::now() - t1));
    const auto t2 = Clock::now();
    (void)alone.Commit(r, {}, kCaller);
    memory_ms.push_back(Ms(Clock::now() - t2));
  }
  std::printf(
      "| commits | through etcd p50 / p99 [ms] | in memory p50 / p99 [ms] | "
      "A's commit → B holds it p50 / p99 [ms] |\n|---|---|---|---|\n");
  std::printf("| %d | %.2f / %.2f | %.3f / %.3f | %.2f / %.2f |\n\n", commits, Median(shared_ms),
              Quantile(shared_ms, 0.99), Median(memory_ms), Quantile(memory_ms, 0.99),
              Median(propagation_ms), Quantile(propagation_ms, 0.99));
}

struct FleetFigures {
  std::atomic<int> asked{0}, planned{0}, refused{0}, failed{0}, races{0};
  std::mutex mutex;
  std::vector<double> plan_commit_ms, commit_ms;
  std::vector<std::pair<int, FleetMotion>> committed;  // (robot, motion), every commit.
};

// One replica's planner: its robots' tasks, each on arrival, until `wall_end`.
void DriveRobots(Replica& replica, const std::string& map, const strata::bench::FleetSite& site,
                 const std::vector<int>& robots, const std::function<std::int64_t()>& now_ns,
                 const std::function<Clock::time_point(std::int64_t)>& wall_of,
                 Clock::time_point wall_end, unsigned seed, FleetFigures& figures) {
  const strata::RobotProfile profile = strata::BuiltinProfile("differential").value();
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, site.nodes.size() - 1);
  // When each robot is next ready (its arrival, or a retry), and its motion.
  std::vector<std::int64_t> ready(robots.size(), now_ns());
  std::vector<FleetMotion> motion(robots.size());  // Each parked where RunFleet put it.
  const ReservationSchedule::Listing parked = replica.schedule.List(map);
  for (std::size_t i = 0; i < robots.size(); ++i) {
    for (const Reservation& r : parked.reservations) {
      if (r.reserved.robot_id == std::to_string(robots[i])) motion[i] = r.reserved.motion;
    }
  }
  while (true) {
    const auto next = std::min_element(ready.begin(), ready.end());
    const std::size_t i = static_cast<std::size_t>(next - ready.begin());
    const Clock::time_point when = wall_of(*next);
    if (when >= wall_end) return;
    std::this_thread::sleep_until(when);  // Pacing a load generator: the robot is not ready.
    const std::int64_t departure = now_ns();
    const std::string robot = std::to_string(robots[i]);
    const Eigen::Vector3d at = motion[i].ReferencePointAt(departure);
    strata::server::ReservationSchedule::Traffic traffic = replica.schedule.OthersOf(map, robot);
    Eigen::Vector3d goal = at;
    for (int tries = 0; tries < 1000; ++tries) {
      goal = site.nodes[pick(rng)];
      bool apart = (goal - at).norm() >= kMinTaskLengthM;
      for (const strata::ReservedMotion& other : traffic.others) {
        apart =
            apart && (goal - other.motion.ReferencePointAt(departure)).norm() >= kMinGoalDistanceM;
      }
      if (apart) break;
    }
    ++figures.asked;
    strata::FleetPlanRequest request;
    request.plan.start.position_m = at;
    request.plan.goal.position_m = goal;
    request.plan.profile = profile;
    request.departure_ns = departure;
    request.parked_until_ns = AddSeconds(departure, kParkedLeaseS);
    const auto t0 = Clock::now();
    bool done = false;
    for (int attempt = 1; attempt <= kMaxCommitAttempts && !done; ++attempt) {
      request.others = traffic.others;
      auto planned = strata::PlanAmongTraffic(*site.map, request);
      if (!planned) {
        (planned.error().code == strata::ErrorCode::kReservationConflict ? figures.refused
                                                                         : figures.failed)++;
        break;
      }
      Reservation reservation;
      reservation.map_id = map;
      reservation.reserved = {robot, planned.value().motion};
      const auto c0 = Clock::now();
      auto committed = replica.schedule.Commit(reservation, {}, kCaller);
      const auto c1 = Clock::now();
      if (committed.ok()) {
        std::lock_guard lock(figures.mutex);
        figures.commit_ms.push_back(Ms(c1 - c0));
        figures.plan_commit_ms.push_back(Ms(c1 - t0));
        figures.committed.emplace_back(robots[i], planned.value().motion);
        motion[i] = planned.value().motion;
        ready[i] = motion[i].ArrivalNs();
        ++figures.planned;
        done = true;
      } else {
        ++figures.races;  // Another commit got in first: plan again against it.
        traffic = replica.schedule.OthersOf(map, robot);
      }
    }
    if (!done) ready[i] = AddSeconds(departure, kRetryAfterS);
  }
}

void RunFleet(const std::string& endpoint, const strata::bench::FleetSite& site, int robots,
              int replicas, double seconds, double speedup, unsigned seed) {
  const auto wall_start = Clock::now();
  const std::int64_t clock_start = strata::server::SystemNowNs();
  const auto now_ns = [=] {
    return AddSeconds(clock_start,
                      speedup * std::chrono::duration<double>(Clock::now() - wall_start).count());
  };
  const auto wall_of = [=](std::int64_t time_ns) {
    return wall_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                            strata::SecondsBetween(clock_start, time_ns) / speedup));
  };
  const std::string map = fmt::format("fleet-{}-{}", replicas, clock_start);
  std::vector<std::unique_ptr<Replica>> shares;
  for (int k = 0; k < replicas; ++k) {
    shares.push_back(std::make_unique<Replica>(endpoint, "/strata-bench", now_ns));
  }
  // Every robot parked at a node apart from the others, committed before any plan.
  const strata::FleetBody body =
      strata::FleetBody::FromProfile(strata::BuiltinProfile("differential").value());
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, site.nodes.size() - 1);
  std::vector<Eigen::Vector3d> places;
  for (int r = 0; r < robots; ++r) {
    Eigen::Vector3d at;
    for (int tries = 0; tries < 1000; ++tries) {
      at = site.nodes[pick(rng)];
      bool apart = true;
      for (const Eigen::Vector3d& p : places) apart = apart && (p - at).norm() >= kMinGoalDistanceM;
      if (apart) break;
    }
    places.push_back(at);
    auto parked = shares[0]->schedule.Commit(
        Parked(map, std::to_string(r), at, now_ns(), kParkedLeaseS, body), {}, kCaller);
    if (!parked.ok()) {
      std::fprintf(stderr, "parking robot %d: %s\n", r, parked.error().message.c_str());
      return;
    }
  }
  for (auto& share : shares) {  // Every replica holds every parked robot before planning.
    std::uint64_t seen = share->schedule.List(map).revision;
    while (share->schedule.List(map).reservations.size() < static_cast<std::size_t>(robots)) {
      seen = share->schedule.WaitForChange(map, seen, Clock::now() + std::chrono::seconds(10));
    }
  }
  FleetFigures figures;
  const auto run_start = Clock::now();
  const auto wall_end = run_start + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(seconds));
  std::vector<std::thread> threads;
  for (int k = 0; k < replicas; ++k) {
    std::vector<int> mine;
    for (int r = k; r < robots; r += replicas) mine.push_back(r);
    threads.emplace_back([&, k, mine] {
      DriveRobots(*shares[k], map, site, mine, now_ns, wall_of, wall_end, seed + 17 * k, figures);
    });
  }
  for (std::thread& t : threads) t.join();
  const double wall_s = std::chrono::duration<double>(Clock::now() - run_start).count();

  // Each robot's motions, each cut at its next departure, checked in pairs.
  std::vector<std::pair<int, FleetMotion>>& all = figures.committed;
  std::vector<int> last(robots, -1);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const int robot = all[i].first;
    if (last[robot] >= 0) {
      FleetMotion& before = all[last[robot]].second;
      before.end_ns = std::max(all[i].second.start_ns, before.ArrivalNs());
    }
    last[robot] = static_cast<int>(i);
  }
  const strata::RobotProfile profile = strata::BuiltinProfile("differential").value();
  const double limit_m = 2 * body.radius_m + strata::SeparationRule{}.separation_m;
  const double relative_speed = 2 * profile.max_speed_horizontal_mps * kHorizontalSpeedSlack;
  int conflicts = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    for (std::size_t j = i + 1; j < all.size(); ++j) {
      if (all[i].first == all[j].first) continue;
      const auto s =
          strata::bench::SampleSeparation(all[i].second, all[j].second, limit_m, relative_speed);
      conflicts += s.first_conflict_ns ? 1 : 0;
    }
  }
  std::printf(
      "| %d | %d | %.0f s | %d of %d (%.1f%%) | %d | %d | %.2f | %.1f / %.1f / %.1f | "
      "%.2f / %.2f | %d |\n",
      robots, replicas, wall_s, figures.planned.load(), figures.asked.load(),
      100.0 * figures.planned.load() / std::max(1, figures.asked.load()), figures.refused.load(),
      figures.races.load(), figures.planned.load() / wall_s, Median(figures.plan_commit_ms),
      Quantile(figures.plan_commit_ms, 0.95), Quantile(figures.plan_commit_ms, 0.99),
      Median(figures.commit_ms), Quantile(figures.commit_ms, 0.99), conflicts);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::string etcd;
  int commits = 500;
  int robots = 40;
  double seconds = 60;
  double speedup = 10;
  unsigned seed = 1;
  CLI::App app{"The fleet's schedule shared by two replicas through etcd"};
  app.add_option("--etcd", etcd, "host:port of a running etcd (bench/with_etcd.sh)")->required();
  app.add_option("--commits", commits, "Commits timed one after another")
      ->check(CLI::Range(1, 100000));
  app.add_option("--robots", robots, "Robots of the fleet run")->check(CLI::Range(2, 500));
  app.add_option("--seconds", seconds, "Wall seconds of each fleet run")
      ->check(CLI::PositiveNumber);
  app.add_option("--speedup", speedup, "How much faster the robots' clock runs than the wall's")
      ->check(CLI::Range(1.0, 100.0));
  app.add_option("--seed", seed, "Seed of the places and tasks");
  CLI11_PARSE(app, argc, argv);
  strata::server::SetLogLevel(strata::server::LogLevel::kWarning);

  MeasureCommits(etcd, commits);
  const strata::RobotProfile profile = strata::BuiltinProfile("differential").value();
  auto cloud = strata::GenerateScene("parking_garage", 1);
  if (!cloud) return 1;
  auto site = strata::bench::MakeFleetSite("parking_garage", *cloud, 0.2, profile);
  if (!site) return 1;
  std::printf(
      "| robots | replicas | wall | tasks planned | refused (conflict) | commits lost "
      "to another replica (replanned) | plans/s | plan + commit p50 / p95 / p99 [ms] | "
      "commit p50 / p99 [ms] | conflicting pairs (1 ms check) |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const int replicas : {1, 2}) RunFleet(etcd, *site, robots, replicas, seconds, speedup, seed);
  return 0;
}
