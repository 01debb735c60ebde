#include "offline/plan_command.hpp"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>

#include <fmt/format.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "offline/assessed_map.hpp"
#include "offline/command_line.hpp"
#include "offline/plan_svg.hpp"
#include "strata/common/parse_numbers.hpp"
#include "strata/planner.hpp"

namespace strata::offline {
namespace {

struct PlanArgs {
  std::string map;
  AssessmentConfig assessment;
  std::string robot = "differential";
  std::optional<Eigen::Vector3d> start;
  std::optional<Eigen::Vector3d> goal;
  PlanOptions options;
  bool json = false;
  std::string svg_path;  // Empty: no drawing.
  bool progress = false;
};

// "x,y,z" in metres, three finite numbers.
std::optional<Eigen::Vector3d> ParsePoint(const std::string& text) {
  std::string error;
  const std::optional<std::array<double, 3>> xyz = common::ParseXyz(text, &error);
  if (!xyz) return std::nullopt;
  return Eigen::Vector3d((*xyz)[0], (*xyz)[1], (*xyz)[2]);
}

// Adds --start or --goal, a required point written x,y,z, parsed into *point.
void AddPointOption(CLI::App& command, const std::string& name, const std::string& help,
                    std::optional<Eigen::Vector3d>* point) {
  command
      .add_option_function<std::string>(
          name, [point](const std::string& text) { *point = ParsePoint(text); }, help)
      ->type_name("X,Y,Z")
      ->required()
      ->check(CLI::Validator(
          [](const std::string& text) {
            return ParsePoint(text) ? std::string() : "needs x,y,z in metres, got '" + text + "'";
          },
          ""));
}

// Reports a failure of the map or the plan: always on stderr, and as JSON on stdout with
// --json so scripts read one document either way.
int Fail(const PlanArgs& args, const Error& error) {
  std::fprintf(stderr, "error: %s: %s\n", ErrorCodeName(error.code), error.message.c_str());
  if (args.json) {
    const nlohmann::json j = {
        {"error", {{"reason", ErrorCodeName(error.code)}, {"message", error.message}}}};
    std::printf("%s\n", j.dump(2).c_str());
  }
  return kExitFailed;
}

Status WriteSvg(const std::string& path, const PlanningMap& map, const RobotProfile& profile,
                const PlanResult& plan, const std::string& map_name) {
  // The graph Plan searched, from the map's cache.
  Expected<std::shared_ptr<const SurfaceGraph>> graph = map.Graph(profile.Traversability());
  if (!graph) return graph.error();
  // Rendered before the file is opened, so errno still tells why opening or writing failed.
  const std::string svg = RenderPlanSvg(**graph, plan, profile, map_name);
  std::ofstream file(path);
  file << svg;
  file.close();
  if (!file) {
    return Error{ErrorCode::kInvalidInput,
                 "cannot write the SVG to '" + path + "': " + std::strerror(errno)};
  }
  return Status::Ok();
}

nlohmann::json PointJson(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

nlohmann::json EndpointJson(const Eigen::Vector3d& requested, const SnapResult& snap) {
  return {{"requested", PointJson(requested)},
          {"snapped", PointJson(snap.position_m)},
          {"level", snap.level},
          {"distance_m", snap.distance_m}};
}

// JSON has no infinity: a headroom with no ceiling above is null.
nlohmann::json FiniteOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json StatsJson(const PlanStats& s) {
  const PlanTimings& t = s.timings;
  return {{"length_m", s.length_m},
          {"duration_s", s.duration_s},
          {"mean_curvature_per_m", s.mean_curvature_per_m},
          {"max_speed_horizontal_mps", s.max_speed_horizontal_mps},
          {"max_speed_vertical_mps", s.max_speed_vertical_mps},
          {"max_accel_horizontal_mps2", s.max_accel_horizontal_mps2},
          {"max_accel_vertical_mps2", s.max_accel_vertical_mps2},
          {"min_obstacle_distance_m", s.min_obstacle_distance_m},
          {"max_ground_offset_m", s.max_ground_offset_m},
          {"max_tilt_rad", s.max_tilt_rad},
          {"min_body_height_m", s.min_body_height_m},
          {"min_headroom_m", FiniteOrNull(s.min_headroom_m)},
          {"pieces", s.pieces},
          {"search_expansions", s.search_expansions},
          {"optimizer_iterations", s.optimizer_iterations},
          {"optimizer_attempts", s.optimizer_attempts},
          {"verified_samples", s.verified_samples},
          {"timings",
           {{"graph_s", t.graph_s},
            {"snap_s", t.snap_s},
            {"search_s", t.search_s},
            {"optimize_s", t.optimize_s},
            {"verify_s", t.verify_s},
            {"total_s", t.total_s}}}};
}

nlohmann::json TrajectoryJson(const Trajectory& trajectory) {
  nlohmann::json pieces = nlohmann::json::array();
  for (const TrajectoryPiece& piece : trajectory.pieces) {
    nlohmann::json axes = nlohmann::json::array();
    for (int a = 0; a < trajectory.dimension; ++a) {
      const Eigen::VectorXd c = piece.coefficients.col(a);
      axes.push_back(std::vector<double>(c.data(), c.data() + c.size()));
    }
    pieces.push_back({{"duration_s", piece.duration_s}, {"coefficients", std::move(axes)}});
  }
  return {{"dimension", trajectory.dimension}, {"pieces", std::move(pieces)}};
}

nlohmann::json PlanJson(const PlanArgs& args, const RobotProfile& profile, const AssessedMap& map,
                        const PlanResult& plan) {
  return {{"map", args.map},
          {"robot", profile.name},
          {"map_seconds", {{"load", map.load_s}, {"assess", map.model->summary().timings.total_s}}},
          {"start", EndpointJson(*args.start, plan.start)},
          {"goal", EndpointJson(*args.goal, plan.goal)},
          {"stats", StatsJson(plan.stats)},
          {"trajectory", TrajectoryJson(plan.trajectory)}};
}

std::string FormatPoint(const Eigen::Vector3d& p) {
  return fmt::format("({:.2f}, {:.2f}, {:.2f})", p.x(), p.y(), p.z());
}

void PrintEndpoint(const char* name, const Eigen::Vector3d& requested, const SnapResult& snap) {
  std::printf("%-12s %s m -> %s m, level %d, %.2f m away\n", name, FormatPoint(requested).c_str(),
              FormatPoint(snap.position_m).c_str(), snap.level, snap.distance_m);
}

void PrintPieces(const Trajectory& trajectory) {
  static constexpr const char* kAxisNames[] = {"x", "y", "z", "h"};
  std::printf("pieces       duration, then c0..c5 per axis: p(t) = sum c_k t^k, t in [0, T]\n");
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[i];
    std::printf("  %-4zu T = %.6g s\n", i, piece.duration_s);
    for (int a = 0; a < trajectory.dimension; ++a) {
      std::printf("       %s", kAxisNames[a]);
      for (int k = 0; k < 6; ++k) std::printf(" %14.6g", piece.coefficients(k, a));
      std::printf("\n");
    }
  }
}

void PrintHuman(const PlanArgs& args, const RobotProfile& profile, const AssessedMap& map,
                const PlanResult& plan) {
  const PlanStats& s = plan.stats;
  const PlanTimings& t = s.timings;
  std::printf("map          %s\n", args.map.c_str());
  std::printf("robot        %s\n", profile.name.c_str());
  PrintEndpoint("start", *args.start, plan.start);
  PrintEndpoint("goal", *args.goal, plan.goal);
  std::printf("length       %.2f m in %.2f s, mean curvature %.4f 1/m\n", s.length_m, s.duration_s,
              s.mean_curvature_per_m);
  std::printf("max speed    %.3f m/s horizontal, %.3f m/s vertical\n", s.max_speed_horizontal_mps,
              s.max_speed_vertical_mps);
  std::printf("max accel    %.3f m/s^2 horizontal, %.3f m/s^2 vertical\n",
              s.max_accel_horizontal_mps2, s.max_accel_vertical_mps2);
  std::printf(
      "margins      obstacle distance >= %.3f m, ground offset <= %.3f m, "
      "tilt <= %.1f deg\n",
      s.min_obstacle_distance_m, s.max_ground_offset_m, s.max_tilt_rad * 180 / std::numbers::pi);
  if (std::isfinite(s.min_headroom_m)) {
    std::printf("body         height >= %.3f m, headroom >= %.3f m\n", s.min_body_height_m,
                s.min_headroom_m);
  } else {
    std::printf("body         height >= %.3f m, no ceiling above\n", s.min_body_height_m);
  }
  std::printf(
      "work         %d pieces, %d A* expansions, %d L-BFGS iterations in %d attempt%s, "
      "%d samples verified\n",
      s.pieces, s.search_expansions, s.optimizer_iterations, s.optimizer_attempts,
      s.optimizer_attempts == 1 ? "" : "s", s.verified_samples);
  std::printf(
      "seconds      load %.3f, assess %.3f | graph %.3f, snap %.3f, search %.3f, optimize "
      "%.3f, verify %.3f, plan total %.3f\n",
      map.load_s, map.model->summary().timings.total_s, t.graph_s, t.snap_s, t.search_s,
      t.optimize_s, t.verify_s, t.total_s);
  PrintPieces(plan.trajectory);
}

int RunPlan(const PlanArgs& parsed) {
  // The name passed BuiltinRobotName when parsed.
  const Expected<RobotProfile> profile = BuiltinProfile(parsed.robot);
  if (!profile) return Fail(parsed, profile.error());
  const Expected<AssessedMap> map =
      LoadAndAssess(parsed.map, parsed.assessment, ProgressLine(parsed.progress));
  if (!map) return Fail(parsed, map.error());

  const PlanningMap planning_map(map->model);
  PlanRequest request;
  request.start.position_m = *parsed.start;
  request.goal.position_m = *parsed.goal;
  request.profile = *profile;
  request.options = parsed.options;
  const Expected<PlanResult> plan = Plan(planning_map, request);
  if (!plan) return Fail(parsed, plan.error());
  // Drawn before anything is printed, so a failed write reports one error, not a plan and then
  // an error.
  if (!parsed.svg_path.empty()) {
    const Status written = WriteSvg(parsed.svg_path, planning_map, *profile, *plan, parsed.map);
    if (!written) return Fail(parsed, written.error());
  }
  if (parsed.json) {
    std::printf("%s\n", PlanJson(parsed, *profile, *map, *plan).dump(2).c_str());
  } else {
    PrintHuman(parsed, *profile, *map, *plan);
  }
  return kExitOk;
}

}  // namespace

void AddPlanCommand(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<PlanArgs>();
  CLI::App* command = app.add_subcommand(
      "plan",
      "Assesses MAP as assess does, then plans a trajectory of the robot's reference point from "
      "start to goal. Prints where start and goal snapped, the plan's figures and its pieces.");
  command->add_option("MAP", args->map, MapHelp())->type_name("")->required();
  AddPointOption(*command, "--start", "start [m], map frame; z picks the level", &args->start);
  AddPointOption(*command, "--goal", "goal [m], map frame; z picks the level", &args->goal);
  command->add_option("--robot", args->robot, "built-in robot profile: " + BuiltinRobotNames())
      ->type_name("NAME")
      ->check(BuiltinRobotName())
      ->capture_default_str();
  command
      ->add_option_function<double>(
          "--time-budget", [args](double seconds) { args->options.time_budget_s = seconds; },
          "wall-clock budget of the whole plan, search included [s]")
      ->type_name("S")
      ->default_str(DefaultText(PlanOptions{}.time_budget_s));
  command->add_flag("--json", args->json, "print the plan as JSON (README.md lists the keys)");
  command->add_option("--svg", args->svg_path, "also draw the plan (top and side view) into FILE")
      ->type_name("FILE");
  AddAssessmentOptions(*command, &args->assessment);
  AddProgressFlag(*command, &args->progress);
  command->callback([args, run] { *run = [args] { return RunPlan(*args); }; });
}

}  // namespace strata::offline
