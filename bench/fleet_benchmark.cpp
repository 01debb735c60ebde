// Fleet figures for docs/benchmarks.md: N robots on one site, each given random reachable
// tasks over simulated minutes, every robot leaving at once at the start. Each fleet size runs
// twice: every robot planned alone (the count of conflicting pairs of committed trajectories
// shows the problem), and planned among the others' committed motions (PlanAmongTraffic:
// 0 conflicts is the target). Both counted by the benchmark's own sampled check
// (oracle/sampled_separation.hpp, 1 ms), never by the planner's. Not part of the test path.
//
//   build/bench/fleet_benchmark [--minutes 10] [--seed 1] [--robots 10 25 50]
//                               [--sites parking_garage spiral] [--replan-robots 0] [--retries 0]
//
// The spiral is the shared map spiral0.3_2 at 0.2 m, read from STRATA_MAPS_DIR. A robot's
// goal is drawn at least 1.5 m from every other robot's position and goal; on arrival it
// gets the next one. A refused request (RESERVATION_CONFLICT) is counted, and 5 simulated
// seconds later the robot asks again: for the same task, up to --retries times (a dispatcher
// that keeps the task while the robots in the way move on), then for another. A task is planned
// when any of its requests is; its delay counts the time it was asked again. Every planned
// trajectory also goes through the benchmark's independent check against the map
// (oracle/independent_check.hpp). A robot refused again and again shows as a stall (from its first
// refusal to its next plan, or to the end); a deadlock would be robots stalled to the end. With
// --replan-robots N a plan may replan up to N robots in its way (ReplanOptions): every simulated
// robot follows the new trajectories it is sent, from the notice on. Prints a markdown table;
// STRATA_FLEET_VERBOSE=1 also prints every refusal (which robot, when, and what the robot it
// names is doing then), every other failure and every conflict the check finds to stderr.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <queue>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "fleet_site.hpp"
#include "independent_check.hpp"
#include "sampled_separation.hpp"
#include "statistics.hpp"
#include "strata/fleet/fleet_plan.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/planner.hpp"
#include "strata/scenes/scenes.hpp"
#include "verifier_bounds.hpp"

namespace {

using strata::FleetMotion;
using strata::PlanningMap;
using strata::bench::Median;
using strata::bench::Quantile;

constexpr std::int64_t kStartNs = 1'795'000'000'000'000'000;  // The simulation's t = 0.
constexpr double kMinGoalDistanceM = 1.5;  // From every other robot's position and goal.
constexpr double kMinTaskLengthM = 3.0;
constexpr double kRetryAfterS = 5.0;
constexpr double kLeaseS = 3600;  // Robots stay parked until their next plan replaces it.
constexpr double kHorizontalSpeedSlack = 1.01;              // The verifier's limit tolerance.
double max_wait_s = strata::FleetPlanOptions{}.max_wait_s;  // --max-wait
int replan_robots = strata::ReplanOptions{}.max_robots;     // --replan-robots
int task_retries = 0;    // --retries: times a refused task is asked again.
int benchmark_sink = 0;  // Keeps the timed checks' results alive.

using Site = strata::bench::FleetSite;

struct Committed {
  int robot;
  FleetMotion motion;
};

struct RunFigures {
  int tasks_asked = 0;  // Each task once, however often it is asked again.
  int tasks_planned = 0;
  int tasks_refused = 0;  // Refused (RESERVATION_CONFLICT) every time it was asked.
  int requests_refused = 0;
  int planned_when_asked_again = 0;
  int failed_other = 0;                  // Any other error.
  int tasks_completed = 0;               // Arrived within the simulated time.
  std::vector<double> latency_ms;        // Plan (+ checks) per request.
  std::vector<double> plain_latency_ms;  // The same task planned alone (fleet runs only).
  std::vector<double> delay_ratio;       // (time asked again + fleet − alone duration) / alone.
  std::vector<double> waits_s;
  int parked_avoided = 0;
  int made_way = 0;            // Tasks whose robot makes way at its goal for a robot passing later.
  int tasks_with_replans = 0;  // Tasks planned by replanning robots in the way.
  int robots_replanned = 0;    // Robots replanned for them, in all.
  std::vector<Committed> committed;
  int conflicting_pairs = 0;  // Pairs of robots whose committed motions conflict.
  int robots_in_conflict = 0;
  long check_samples = 0;
  double exact_checks_per_s = 0;  // FirstConflict over the committed pairs that overlap in time.
  strata::bench::IndependentCheckTally map_check;  // Every planned trajectory against the map.
  double longest_stall_s = 0;  // A robot's first refusal to its next plan (or the end).
  int stalled_at_end = 0;      // Robots refused from over a minute before the end to the end.
};

/// What a robot in the way is doing at `now` on its committed `motion`, for the verbose
/// refusals: whether replanning it would mean replanning a robot under way.
std::string WhatItIsDoing(const FleetMotion& motion, std::int64_t now) {
  if (now >= motion.ArrivalNs()) return "parked at its goal";
  const double t = motion.TrajectoryTimeAt(now);
  if (!motion.trajectory.Velocity(t).isZero(1e-9)) {
    return fmt::format("under way, {:.0f} s from its goal",
                       strata::SecondsBetween(now, motion.ArrivalNs()));
  }
  double first_move_s = 0;  // Trajectory time of its first piece that moves.
  for (const strata::TrajectoryPiece& piece : motion.trajectory.pieces) {
    if (!piece.coefficients.bottomRows(5).isZero(1e-12)) break;
    first_move_s += piece.duration_s;
  }
  return t < first_move_s ? fmt::format("holding before it leaves, for {:.0f} s", first_move_s - t)
                          : "holding on its way";
}

double Ms(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

/// Runs one fleet on one site for `minutes`; `with_reservations` plans among the others.
RunFigures RunFleet(const Site& site, int robots, double minutes, unsigned seed,
                    bool with_reservations, const strata::RobotProfile& profile) {
  RunFigures figures;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, site.nodes.size() - 1);
  const std::int64_t end_ns = strata::AddSeconds(kStartNs, minutes * 60);
  const strata::FleetBody body = strata::FleetBody::FromProfile(profile);
  const double separation_m = strata::SeparationRule{}.separation_m;  // Every robot's.
  const double limit_m = 2 * body.radius_m + separation_m;

  // Each robot's current motion (an index into figures.committed), starting parked.
  std::vector<std::size_t> current(robots);
  // When each robot's current motion first reaches its goal (before the trajectory's end when
  // it makes way there); none for the robots standing at the start.
  std::vector<std::int64_t> arrival_at_goal(robots, std::numeric_limits<std::int64_t>::max());
  std::vector<Eigen::Vector3d> goals(robots);
  // When each robot's current run of refusals began (none: nullopt).
  std::vector<std::optional<std::int64_t>> refused_since(robots);
  // Each robot's task: its goal, when it was first asked, and how often it has been refused.
  std::vector<Eigen::Vector3d> task_goal(robots);
  std::vector<std::int64_t> task_asked_ns(robots, kStartNs);
  std::vector<int> task_refusals(robots, 0);
  // When each robot is next asked for a task: events for any other time are dropped (a
  // robot replanned for another arrives at another time).
  std::vector<std::int64_t> next_event(robots, kStartNs);
  const auto end_stall = [&](int robot, std::int64_t at) {
    if (!refused_since[robot]) return;
    figures.longest_stall_s =
        std::max(figures.longest_stall_s, strata::SecondsBetween(*refused_since[robot], at));
    refused_since[robot].reset();
  };
  for (int r = 0; r < robots; ++r) {
    Eigen::Vector3d at;
    for (int tries = 0; tries < 1000; ++tries) {
      at = site.nodes[pick(rng)];
      bool apart = true;
      for (int k = 0; k < r; ++k) apart = apart && (goals[k] - at).norm() >= kMinGoalDistanceM;
      if (apart) break;
    }
    goals[r] = at;
    Committed parked{r, {}};
    parked.motion.start_ns = kStartNs;
    strata::TrajectoryPiece stand;
    stand.duration_s = 0.1;
    stand.coefficients = Eigen::Matrix<double, 6, 3>::Zero();
    stand.coefficients.row(0) = at.transpose();
    parked.motion.trajectory.pieces.push_back(stand);
    parked.motion.body = body;
    parked.motion.end_ns = strata::AddSeconds(kStartNs, kLeaseS);
    parked.motion.separation_m = separation_m;
    current[r] = figures.committed.size();
    figures.committed.push_back(std::move(parked));
  }

  using Event = std::pair<std::int64_t, int>;  // (time, robot), earliest first.
  std::priority_queue<Event, std::vector<Event>, std::greater<>> events;
  // `robot`'s current motion replaced by `next` from its start on (a robot replanned to let
  // another pass first): it arrives at its goal, and gets its next task, when `next` does.
  const auto replace_motion = [&](int robot, const FleetMotion& next) {
    figures.map_check.Add(strata::bench::CheckTrajectory(
        site.map->model(), profile, next.trajectory,
        strata::bench::CheckConfigFor(strata::PlanOptions{}.verifier, site.map->keep_out())));
    figures.committed[current[robot]].motion.end_ns = next.start_ns;
    figures.tasks_completed +=
        (next.ArrivalNs() <= end_ns ? 1 : 0) - (arrival_at_goal[robot] <= end_ns ? 1 : 0);
    arrival_at_goal[robot] = next.ArrivalNs();
    current[robot] = figures.committed.size();
    figures.committed.push_back({robot, next});
    ++figures.robots_replanned;
    next_event[robot] = next.ArrivalNs();
    events.emplace(next.ArrivalNs(), robot);
  };
  for (int r = 0; r < robots; ++r) events.emplace(kStartNs, r);
  while (!events.empty()) {
    const auto [now, robot] = events.top();
    events.pop();
    if (now >= end_ns || now != next_event[robot]) continue;
    const Eigen::Vector3d at = figures.committed[current[robot]].motion.ReferencePointAt(now);
    const bool asked_again = task_refusals[robot] > 0;
    // A new task: a goal apart from every other robot's position now and its goal.
    Eigen::Vector3d goal = asked_again ? task_goal[robot] : at;
    for (int tries = 0; tries < 1000 && !asked_again; ++tries) {
      goal = site.nodes[pick(rng)];
      bool apart = (goal - at).norm() >= kMinTaskLengthM;
      for (int k = 0; k < robots && apart; ++k) {
        if (k == robot) continue;
        const FleetMotion& other = figures.committed[current[k]].motion;
        apart = (goal - other.ReferencePointAt(now)).norm() >= kMinGoalDistanceM &&
                (goal - goals[k]).norm() >= kMinGoalDistanceM;
      }
      if (apart) break;
    }
    if (!asked_again) {
      ++figures.tasks_asked;
      task_goal[robot] = goal;
      task_asked_ns[robot] = now;
    }
    strata::PlanRequest request;
    request.start.position_m = at;
    request.goal.position_m = goal;
    request.profile = profile;

    const auto t0 = std::chrono::steady_clock::now();
    std::optional<strata::Trajectory> trajectory;
    bool refused = false;  // RESERVATION_CONFLICT
    double arrival_s = 0;  // When the trajectory first reaches the goal.
    if (with_reservations) {
      std::vector<strata::ReservedMotion> others;
      others.reserve(robots - 1);
      for (int k = 0; k < robots; ++k) {
        if (k != robot) others.push_back({std::to_string(k), figures.committed[current[k]].motion});
      }
      strata::FleetPlanRequest fleet;
      fleet.plan = request;
      fleet.departure_ns = now;
      fleet.parked_until_ns = strata::AddSeconds(now, kLeaseS);
      fleet.others = others;
      fleet.fleet.max_wait_s = max_wait_s;
      // Every robot of the simulation follows the new trajectories it is sent.
      std::vector<strata::ReplannableRobot> replannable;
      for (std::size_t i = 0; i < others.size(); ++i) replannable.push_back({i, profile});
      fleet.replannable = replannable;
      fleet.fleet.replan.max_robots = replan_robots;
      auto planned = strata::PlanAmongTraffic(*site.map, fleet);
      figures.latency_ms.push_back(Ms(std::chrono::steady_clock::now() - t0));
      if (planned) {
        for (const strata::ReplannedRobot& replanned : planned.value().replanned) {
          replace_motion(std::stoi(others[replanned.other].robot_id), replanned.motion);
        }
        figures.tasks_with_replans += planned.value().replanned.empty() ? 0 : 1;
        trajectory = planned.value().plan.trajectory;
        arrival_s = planned.value().arrival_s;
        figures.made_way += planned.value().makes_way ? 1 : 0;
        figures.parked_avoided += planned.value().parked_robots_avoided;
        figures.waits_s.push_back(planned.value().wait_s);
      } else if (planned.error().code == strata::ErrorCode::kReservationConflict) {
        refused = true;
        ++figures.requests_refused;
        ++task_refusals[robot];
        if (std::getenv("STRATA_FLEET_VERBOSE")) {
          std::string in_the_way;
          const auto& details = planned.error().details;
          if (const auto named = details.find("robot_id"); named != details.end()) {
            const FleetMotion& other = figures.committed[current[std::stoi(named->second)]].motion;
            in_the_way = fmt::format(" [robot {}: {}]", named->second, WhatItIsDoing(other, now));
          }
          std::fprintf(stderr, "refused robot %d at %.1f s: %s%s\n", robot,
                       strata::SecondsBetween(kStartNs, now), planned.error().message.c_str(),
                       in_the_way.c_str());
        }
      } else {
        ++figures.failed_other;
        if (std::getenv("STRATA_FLEET_VERBOSE"))
          std::fprintf(stderr, "failed: %s\n", planned.error().message.c_str());
      }
      // The same task alone, for the delay and the plain latency.
      const auto t1 = std::chrono::steady_clock::now();
      auto alone = strata::Plan(*site.map, request);
      figures.plain_latency_ms.push_back(Ms(std::chrono::steady_clock::now() - t1));
      if (alone && trajectory) {
        const double plain = alone.value().trajectory.TotalDuration();
        const double asked_s = strata::SecondsBetween(task_asked_ns[robot], now);
        figures.delay_ratio.push_back((asked_s + arrival_s - plain) / plain);
      }
    } else {
      auto alone = strata::Plan(*site.map, request);
      figures.latency_ms.push_back(Ms(std::chrono::steady_clock::now() - t0));
      if (alone) {
        trajectory = alone.value().trajectory;
        arrival_s = trajectory->TotalDuration();
      } else {
        ++figures.failed_other;
        if (std::getenv("STRATA_FLEET_VERBOSE"))
          std::fprintf(stderr, "failed alone: %s\n", alone.error().message.c_str());
      }
    }
    // The next request is for this task again only after a refusal within --retries.
    if (!refused || task_refusals[robot] > task_retries) {
      figures.tasks_refused += refused ? 1 : 0;
      task_refusals[robot] = 0;
    }
    if (!trajectory) {
      if (!refused_since[robot]) refused_since[robot] = now;
      // A robot making way at its goal is asked again at rest: holding, or back at the goal.
      const FleetMotion& mine = figures.committed[current[robot]].motion;
      std::int64_t retry = strata::AddSeconds(now, kRetryAfterS);
      if (!mine.trajectory.Velocity(mine.TrajectoryTimeAt(retry)).isZero(1e-9)) {
        retry = mine.ArrivalNs();
      }
      next_event[robot] = retry;
      events.emplace(retry, robot);
      continue;
    }
    end_stall(robot, now);
    ++figures.tasks_planned;
    figures.planned_when_asked_again += asked_again ? 1 : 0;
    figures.map_check.Add(strata::bench::CheckTrajectory(
        site.map->model(), profile, *trajectory,
        strata::bench::CheckConfigFor(request.options.verifier, site.map->keep_out())));
    // The new motion replaces the robot's current one from now on: after its arrival, or at
    // its arrival at the goal where it was to make way there (dropping that part).
    FleetMotion& mine = figures.committed[current[robot]].motion;
    mine.end_ns = std::max(now, std::min(mine.ArrivalNs(), arrival_at_goal[robot]));
    Committed next{robot, {}};
    next.motion.start_ns = now;
    next.motion.trajectory = std::move(*trajectory);
    next.motion.body = body;
    next.motion.end_ns = strata::AddSeconds(now, kLeaseS);
    next.motion.separation_m = separation_m;  // What each robot asks, as a server keeps it.
    const std::int64_t arrival = strata::AddSeconds(now, arrival_s);
    arrival_at_goal[robot] = arrival;
    if (arrival <= end_ns) ++figures.tasks_completed;
    goals[robot] = goal;
    current[robot] = figures.committed.size();
    figures.committed.push_back(std::move(next));
    next_event[robot] = arrival;
    events.emplace(arrival, robot);
  }

  for (int r = 0; r < robots; ++r) {
    if (refused_since[r] && strata::SecondsBetween(*refused_since[r], end_ns) > 60) {
      ++figures.stalled_at_end;
    }
    end_stall(r, end_ns);
  }
  // The benchmark's own check over every pair of committed motions of two robots, over the
  // simulated time (the last motions stay parked for their lease beyond it).
  for (Committed& c : figures.committed) {
    c.motion.end_ns = std::min(c.motion.end_ns, std::max(end_ns, c.motion.ArrivalNs()));
  }
  const double relative_speed = 2 * profile.max_speed_horizontal_mps * kHorizontalSpeedSlack;
  std::map<std::pair<int, int>, bool> conflicting;
  for (std::size_t i = 0; i < figures.committed.size(); ++i) {
    for (std::size_t j = i + 1; j < figures.committed.size(); ++j) {
      const Committed& a = figures.committed[i];
      const Committed& b = figures.committed[j];
      if (a.robot == b.robot) continue;
      const auto key = std::minmax(a.robot, b.robot);
      if (conflicting.count(key)) continue;
      const auto s = strata::bench::SampleSeparation(a.motion, b.motion, limit_m, relative_speed);
      figures.check_samples += s.samples;
      if (s.first_conflict_ns) {
        conflicting[key] = true;
        if (std::getenv("STRATA_FLEET_VERBOSE")) {
          const auto pa = a.motion.ReferencePointAt(*s.first_conflict_ns);
          const auto pb = b.motion.ReferencePointAt(*s.first_conflict_ns);
          std::fprintf(stderr, "conflict %d-%d at %.3f s: (%.2f %.2f %.2f) (%.2f %.2f %.2f)\n",
                       a.robot, b.robot, strata::SecondsBetween(kStartNs, *s.first_conflict_ns),
                       pa.x(), pa.y(), pa.z(), pb.x(), pb.y(), pb.z());
        }
      }
    }
  }
  // The planner's exact check over the same pairs that share time, timed.
  {
    const strata::SeparationRule rule;
    long checks = 0;
    int found = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < figures.committed.size(); ++i) {
      for (std::size_t j = i + 1; j < figures.committed.size(); ++j) {
        const FleetMotion& a = figures.committed[i].motion;
        const FleetMotion& b = figures.committed[j].motion;
        if (figures.committed[i].robot == figures.committed[j].robot ||
            std::max(a.start_ns, b.start_ns) > std::min(a.end_ns, b.end_ns)) {
          continue;
        }
        ++checks;
        found += strata::FirstConflict(a, b, rule) ? 1 : 0;
      }
    }
    const double seconds = Ms(std::chrono::steady_clock::now() - t0) / 1000;
    figures.exact_checks_per_s = seconds > 0 ? static_cast<double>(checks) / seconds : 0;
    benchmark_sink += found;
  }
  figures.conflicting_pairs = static_cast<int>(conflicting.size());
  std::vector<bool> involved(robots, false);
  for (const auto& [pair, _] : conflicting) involved[pair.first] = involved[pair.second] = true;
  figures.robots_in_conflict = static_cast<int>(std::count(involved.begin(), involved.end(), true));
  return figures;
}

std::string Percent(int part, int whole) {
  return fmt::format("{:.1f}%", whole > 0 ? 100.0 * part / whole : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  double minutes = 10;
  unsigned seed = 1;
  std::vector<int> fleet_sizes = {10, 25, 50};
  std::vector<std::string> site_names = {"parking_garage", "spiral"};
  CLI::App app{"Fleet figures: robots planned alone and among each other's reservations"};
  app.add_option("--minutes", minutes, "Simulated minutes per run")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "Seed of the start positions and tasks");
  app.add_option("--robots", fleet_sizes, "Fleet sizes")->check(CLI::Range(1, 500));
  app.add_option("--sites", site_names, "parking_garage (generated), spiral (STRATA_MAPS_DIR)")
      ->check(CLI::IsMember({"parking_garage", "spiral"}));
  app.add_option("--replan-robots", replan_robots,
                 "Robots in the way a plan may replan, in all (ReplanOptions::max_robots)")
      ->check(CLI::Range(0, strata::kMaxReplannedRobots));
  app.add_option("--retries", task_retries,
                 "Times a refused task is asked again, 5 s later each, before the next task")
      ->check(CLI::Range(0, 1000));
  app.add_option("--max-wait", max_wait_s, "Longest the robots wait, in all [s]")
      ->check(CLI::Range(0.0, 3600.0));
  CLI11_PARSE(app, argc, argv);
  const strata::RobotProfile profile = strata::BuiltinProfile("differential").value();

  std::vector<Site> sites;
  for (const std::string& name : site_names) {
    if (name == "parking_garage") {
      auto cloud = strata::GenerateScene("parking_garage", 1);
      if (!cloud) return 1;
      auto site = strata::bench::MakeFleetSite(name, *cloud, 0.2,
                                               profile);  // docs/scenes.md: its resolution.
      if (!site) return 1;
      sites.push_back(std::move(*site));
    } else if (const char* dir = std::getenv("STRATA_MAPS_DIR")) {
      auto cloud = strata::LoadPointCloud(std::string(dir) + "/spiral0.3_2.pcd", {});
      if (!cloud) return 1;
      auto site = strata::bench::MakeFleetSite("spiral@0.2", cloud->points, 0.2, profile);
      if (!site) return 1;
      sites.push_back(std::move(*site));
    } else {
      std::fprintf(stderr, "spiral: set STRATA_MAPS_DIR to the shared maps; skipped\n");
    }
  }

  std::printf(
      "Fleets of differential robots (radius 0.3 m, separation 0.1 m), %.0f simulated "
      "minutes, seed %u; a refused task is asked again up to %d times.\n\n",
      minutes, seed, task_retries);
  std::printf(
      "| site | robots | reservations | tasks planned | refused (conflict): tasks "
      "(requests) | planned when asked again | failed (other) | conflicting pairs (robots) | plan "
      "p50 / p95 / max [ms] | alone p50 / p95 "
      "[ms] | mean delay | waits | parked robots avoided | robots replanned (for tasks) | exact "
      "checks/s | map check | longest stall (stalled at the end) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Site& site : sites) {
    for (const int robots : fleet_sizes) {
      for (const bool with : {false, true}) {
        const RunFigures f = RunFleet(site, robots, minutes, seed, with, profile);
        double mean_delay = 0;
        for (double d : f.delay_ratio) mean_delay += d;
        if (!f.delay_ratio.empty()) mean_delay /= static_cast<double>(f.delay_ratio.size());
        const int waited = static_cast<int>(
            std::count_if(f.waits_s.begin(), f.waits_s.end(), [](double w) { return w > 0; }));
        // The columns of the runs among reservations only: "-" for the runs alone.
        const auto among = [with](const std::string& text) { return with ? text : "-"; };
        std::fputs(
            fmt::format(
                "| {} | {} | {} | {} of {} ({}) | {} ({}) | {} | {} | {} ({}) | {:.1f} / {:.1f} / "
                "{:.0f} | "
                "{} | {} | "
                "{} | {} | {} | {:.0f} | {} | {:.0f} s ({}) |\n",
                site.name, robots, with ? "yes" : "no", f.tasks_planned, f.tasks_asked,
                Percent(f.tasks_planned, f.tasks_asked), f.tasks_refused, f.requests_refused,
                among(std::to_string(f.planned_when_asked_again)), f.failed_other,
                f.conflicting_pairs, f.robots_in_conflict, Median(f.latency_ms),
                Quantile(f.latency_ms, 0.95), Quantile(f.latency_ms, 1.0),
                among(fmt::format("{:.1f} / {:.1f}", Median(f.plain_latency_ms),
                                  Quantile(f.plain_latency_ms, 0.95))),
                among(fmt::format("{:.1f}%", 100 * mean_delay)),
                among(fmt::format("{} tasks ({} made way at the goal)", waited, f.made_way)),
                among(std::to_string(f.parked_avoided)),
                among(fmt::format("{} ({})", f.robots_replanned, f.tasks_with_replans)),
                f.exact_checks_per_s, f.map_check.Describe(), f.longest_stall_s, f.stalled_at_end)
                .c_str(),
            stdout);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
