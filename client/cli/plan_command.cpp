// `strata plan`: one Plan call, printed as a summary or as the PlanResponse in JSON.
#include <cmath>

#include <fmt/format.h>

#include "commands.hpp"
#include "connection.hpp"
#include "output.hpp"
#include "strata/client/polynomial_trajectory.hpp"
#include "strata/client/rpc.hpp"
#include "strata/v1/planner_service.grpc.pb.h"

namespace strata::cli {
namespace {

void SetVector(const std::array<double, 3>& xyz, v1::Vector3* v) {
  v->set_x(xyz[0]);
  v->set_y(xyz[1]);
  v->set_z(xyz[2]);
}

v1::Vector3 ToVector(const Eigen::Vector3d& p) {
  v1::Vector3 v;
  v.set_x(p.x());
  v.set_y(p.y());
  v.set_z(p.z());
  return v;
}

// Where a start or goal landed, said from the requested point: on it (only z set to the
// reference height above the ground), or moved to the centre of the nearest column.
void PrintSnapped(std::ostream& out, const char* name, const v1::SnappedState& state,
                  const v1::Vector3* requested) {
  if (requested == nullptr) {
    out << "  " << name << FormatVector(state.position_m()) << " m, on the ground at "
        << Fixed(state.ground_height_m(), 2) << " m (level " << state.level()
        << " of its column)\n";
    return;
  }
  const double moved_m =
      std::hypot(state.position_m().x() - requested->x(), state.position_m().y() - requested->y());
  out << "  " << name << FormatVector(state.position_m()) << " m, on the ground at "
      << Fixed(state.ground_height_m(), 2) << " m (level " << state.level() << " of its column)";
  if (moved_m < 1e-3) {
    out << ", at the requested x, y\n";
  } else {
    out << ", moved " << Fixed(moved_m, 3) << " m from the requested x, y (to the nearest "
        << "column with ground)\n";
  }
}

void PrintSummary(const Context& ctx, const v1::PlanRequest& request,
                  const v1::PlanResponse& response) {
  std::ostream& out = *ctx.out;
  const v1::PlanStats& stats = response.stats();
  out << "plan on map " << request.map_id() << " for robot " << response.profile().name() << ": "
      << Fixed(stats.length_m(), 2) << " m in " << Fixed(stats.duration_s(), 2) << " s, "
      << stats.pieces() << " pieces\n";
  const auto asked = [](const auto& end) {
    return end.has_position_m() ? &end.position_m() : nullptr;
  };
  PrintSnapped(out, "start ", response.start(), asked(request.start()));
  PrintSnapped(out, "goal  ", response.goal(), asked(request.goal()));
  for (int i = 0; i < request.via_size() && i < response.via_times_s_size(); ++i) {
    out << "  via[" << i << "] " << FormatVector(request.via(i).position_m()) << " m "
        << (request.via(i).stop() ? "stop" : "pass") << " at " << Fixed(response.via_times_s(i), 3)
        << " s\n";
  }
  out << "  speed       max " << Fixed(stats.max_speed_horizontal_mps(), 2) << " m/s horizontal, "
      << Fixed(stats.max_speed_vertical_mps(), 2) << " m/s vertical\n"
      << "  accel       max " << Fixed(stats.max_accel_horizontal_mps2(), 2)
      << " m/s^2 horizontal, " << Fixed(stats.max_accel_vertical_mps2(), 2) << " m/s^2 vertical\n"
      << "  clearance   " << Fixed(stats.min_obstacle_distance_m(), 3)
      << " m to the nearest obstacle; ground offset at most "
      << Fixed(stats.max_ground_offset_m(), 3) << " m; mean curvature "
      << Fixed(stats.mean_curvature_per_m(), 3) << " 1/m\n"
      << "  planning    " << Fixed(stats.timings().total_s(), 3) << " s (graph "
      << Fixed(stats.timings().graph_s(), 3) << " s, snap " << Fixed(stats.timings().snap_s(), 3)
      << " s, search " << Fixed(stats.timings().search_s(), 3) << " s, optimise "
      << Fixed(stats.timings().optimize_s(), 3) << " s, verify "
      << Fixed(stats.timings().verify_s(), 3) << " s; " << stats.optimizer_iterations()
      << " iterations, " << stats.optimizer_attempts() << " attempt(s))\n";
  if (request.has_fleet()) {
    out << "  fleet       robot " << request.fleet().robot_id() << " waits "
        << Fixed(response.wait_s(), 2) << " s for the others";
    for (const v1::Hold& hold : response.holds()) {
      out << (hold.start_s() == 0                     ? ", at the start "
              : hold.start_s() < response.arrival_s() ? ", on the way at "
                                                      : ", making way at its goal at ")
          << Fixed(hold.start_s(), 2) << " s for " << Fixed(hold.duration_s(), 2) << " s";
    }
    out << "; arrives at " << Fixed(response.arrival_s(), 2) << " s";
    if (response.has_reservation()) {
      const v1::Reservation& reserved = response.reservation();
      out << "; reserved from " << FormatTime(reserved.start_time()) << " until "
          << FormatTime(reserved.expiry_time()) << " (revision " << reserved.revision() << ")";
    }
    for (const v1::Reservation& replanned : response.replanned()) {
      out << "; robot " << replanned.robot_id() << " replanned to let it pass (revision "
          << replanned.revision() << ")";
    }
    out << "\n";
  }

  const auto trajectory = client::PolynomialTrajectory::FromPlanResponse(response);
  if (!trajectory) {
    out << "  (" << trajectory.error().message << ")\n";
    return;
  }
  out << "  piece   start_s  duration_s  start position [m]\n";
  for (std::size_t i = 0; i < trajectory->piece_count(); ++i) {
    // Explicit right alignment: fmt would left-align inf and nan in a width.
    out << fmt::format("  {:5}  {:>7.3f}  {:>10.3f}  ", i, trajectory->piece_start_s(i),
                       trajectory->piece_duration_s(i))
        << FormatVector(ToVector(trajectory->PositionAt(trajectory->piece_start_s(i)))) << "\n";
  }
  out << "  end     " << Fixed(trajectory->duration_s(), 3) << "               "
      << FormatVector(ToVector(trajectory->PositionAt(trajectory->duration_s()))) << "\n";
}

}  // namespace

std::vector<CLI::Option*> AddPlanFlags(CLI::App& command, PlanFlags* flags, bool required) {
  std::vector<CLI::Option*> options = {
      command.add_option("--map", flags->map, "map id")->type_name("ID"),
      AddVector3(command, "--start", "start position [m]; z picks the level", &flags->start),
      AddVector3(command, "--goal", "goal position [m]; z picks the level", &flags->goal)};
  for (CLI::Option* option : options) option->required(required);
  options.push_back(command.add_option("--robot", flags->robot, "robot profile")
                        ->type_name("NAME")
                        ->capture_default_str());
  options.push_back(
      command.add_option("--time-budget", flags->time_budget_s, "options.time_budget_s [s]")
          ->type_name("S")
          ->check(FiniteNumber()));
  options.push_back(
      command.add_option("--sample-dt", flags->sample_dt_s, "options.sample_dt_s [s]")
          ->type_name("S")
          ->check(FiniteNumber()));
  options.push_back(
      command
          .add_option_function<std::vector<std::string>>(
              "--via",
              [flags](const std::vector<std::string>& texts) {
                flags->via.clear();
                std::string error;
                for (const std::string& text : texts) flags->via.push_back(*ParseVia(text, &error));
              },
              "a point to pass through on the way, in order (repeat the flag); x,y,z:stop to "
              "come to rest there")
          ->type_name("x,y,z[:stop]")
          ->check(CLI::Validator(
              [](std::string& text) {  // Checked before the function above runs.
                std::string error;
                return ParseVia(text, &error) ? std::string() : error;
              },
              "")));
  options.push_back(command
                        .add_option("--robot-id", flags->robot_id,
                                    "plan among the other robots' reservations on the map, as "
                                    "this robot (fleet.robot_id): wait or go around them")
                        ->type_name("ID"));
  options.push_back(command.add_flag("--reserve", flags->reserve,
                                     "commit the plan as the robot's reservation (fleet.reserve)"));
  options.push_back(command
                        .add_option("--lease", flags->lease_s,
                                    "how long from now the reservation holds the goal "
                                    "(fleet.lease_s) [s]")
                        ->type_name("S")
                        ->check(PositiveNumber()));
  options.push_back(command
                        .add_option("--max-wait", flags->max_wait_s,
                                    "longest the robot waits for others to pass, in all "
                                    "(fleet.max_wait_s) [s]")
                        ->type_name("S")
                        ->check(FiniteNumber()));
  options.push_back(command
                        .add_option("--separation", flags->separation_m,
                                    "free distance kept between two robots' bodies "
                                    "(fleet.separation_m; the server's --separation-m by "
                                    "default) [m]")
                        ->type_name("M")
                        ->check(FiniteNumber()));
  options.push_back(command.add_flag("--follows-replans", flags->follows_replans,
                                     "the robot follows new trajectories the server sends it: "
                                     "other plans may replan it to pass first "
                                     "(fleet.follows_replans; with --reserve)"));
  options.push_back(command
                        .add_option("--replan-robots", flags->replan_robots,
                                    "robots in the way, following replans, that this plan may "
                                    "replan to pass first (fleet.replan_robots; with --reserve)")
                        ->type_name("N"));
  return options;
}

v1::PlanRequest PlanRequestFromFlags(const PlanFlags& flags) {
  if (flags.map.empty() || !flags.start || !flags.goal) {
    throw UsageError(
        "planning needs --map ID, --start x,y,z and --goal x,y,z (setpoints: or --from PLAN.json)");
  }
  v1::PlanRequest request;
  request.set_map_id(flags.map);
  SetVector(*flags.start, request.mutable_start()->mutable_position_m());
  SetVector(*flags.goal, request.mutable_goal()->mutable_position_m());
  request.set_profile_name(flags.robot);
  if (flags.time_budget_s) request.mutable_options()->set_time_budget_s(*flags.time_budget_s);
  if (flags.sample_dt_s) request.mutable_options()->set_sample_dt_s(*flags.sample_dt_s);
  for (const ViaPoint& point : flags.via) {
    v1::Via* via = request.add_via();
    SetVector(point.position_m, via->mutable_position_m());
    via->set_stop(point.stop);
  }
  if (flags.robot_id.empty()) {
    if (flags.reserve || flags.lease_s || flags.max_wait_s || flags.separation_m ||
        flags.follows_replans || flags.replan_robots > 0) {
      throw UsageError(
          "--reserve, --lease, --max-wait, --separation, --follows-replans and --replan-robots "
          "need --robot-id: the robot they are for");
    }
    return request;
  }
  v1::FleetOptions* fleet = request.mutable_fleet();
  fleet->set_robot_id(flags.robot_id);
  fleet->set_reserve(flags.reserve);
  if (flags.lease_s) fleet->set_lease_s(*flags.lease_s);
  if (flags.max_wait_s) fleet->set_max_wait_s(*flags.max_wait_s);
  if (flags.separation_m) fleet->set_separation_m(*flags.separation_m);
  fleet->set_follows_replans(flags.follows_replans);
  fleet->set_replan_robots(flags.replan_robots);
  return request;
}

bool CallPlan(const Context& ctx, const v1::PlanRequest& request, v1::PlanResponse* response) {
  auto stub = v1::PlannerService::NewStub(OpenChannel(ctx));
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  const grpc::Status status = stub->Plan(&call, request, response);
  if (status.ok()) return true;
  ReportRpcError(ctx, "Plan", status);
  return false;
}

void AddPlanCommand(CLI::App& app, const Context& ctx, Command* run) {
  auto [plan, flags] = AddCommand<PlanFlags>(
      app, "plan", "Plan: prints the snapped start and goal, the stats and the pieces", run,
      [&ctx](const PlanFlags& flags) {
        const v1::PlanRequest request = PlanRequestFromFlags(flags);
        v1::PlanResponse response;
        if (!CallPlan(ctx, request, &response)) return kExitRpcError;
        if (ctx.json) {
          *ctx.out << ToJson(response);
        } else {
          PrintSummary(ctx, request, response);
        }
        return kExitOk;
      });
  AddPlanFlags(*plan, flags.get(), /*required=*/true);
}

}  // namespace strata::cli
