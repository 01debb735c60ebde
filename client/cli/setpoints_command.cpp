// `strata setpoints`: MPC setpoints from a fresh plan or a saved PlanResponse (JSON).
#include <cmath>

#include <fmt/format.h>

#include "commands.hpp"
#include "output.hpp"
#include "strata/client/polynomial_trajectory.hpp"
#include "strata/client/setpoints.hpp"

namespace strata::cli {
namespace {

std::string JsonVector(const Eigen::Vector3d& v) {
  return "{\"x\": " + JsonNumber(v.x()) + ", \"y\": " + JsonNumber(v.y()) +
         ", \"z\": " + JsonNumber(v.z()) + "}";
}

// Keys are fixed: body_height_m is null for dimension-3 trajectories.
void PrintJson(std::ostream& out, const client::PolynomialTrajectory& trajectory,
               const std::vector<client::MpcSetpoint>& setpoints) {
  out << "{\n  \"dimension\": " << trajectory.dimension()
      << ",\n  \"duration_s\": " << JsonNumber(trajectory.duration_s()) << ",\n  \"setpoints\": [";
  const char* separator = "\n";
  for (const client::MpcSetpoint& s : setpoints) {
    out << separator << "    {\"time_s\": " << JsonNumber(s.time_s)
        << ", \"position_m\": " << JsonVector(s.position_m)
        << ", \"velocity_mps\": " << JsonVector(s.velocity_mps)
        << ", \"acceleration_mps2\": " << JsonVector(s.acceleration_mps2)
        << ", \"speed_mps\": " << JsonNumber(s.speed_mps)
        << ", \"yaw_rad\": " << JsonNumber(s.yaw_rad)
        << ", \"yaw_rate_radps\": " << JsonNumber(s.yaw_rate_radps)
        << ", \"yaw_held\": " << (s.yaw_held ? "true" : "false") << ", \"body_height_m\": "
        << (s.body_height_m ? JsonNumber(*s.body_height_m) : std::string("null")) << "}";
    separator = ",\n";
  }
  out << "\n  ]\n}\n";
}

void PrintTable(std::ostream& out, const client::PolynomialTrajectory& trajectory,
                const std::vector<client::MpcSetpoint>& setpoints) {
  const bool height = trajectory.dimension() == 4;
  out << "     t_s      x_m      y_m      z_m   yaw_rad    v_mps  omega_radps   ax_mps2   "
         "ay_mps2   az_mps2"
      << (height ? "  body_height_m" : "") << "\n";
  bool any_held = false;
  for (const client::MpcSetpoint& s : setpoints) {
    // Explicit right alignment: fmt would left-align inf and nan in a width.
    out << fmt::format(
        "{:>8.3f} {:>8.3f} {:>8.3f} {:>8.3f} {:>8.4f}{} {:>8.4f} {:>12.4f} {:>9.4f} {:>9.4f} "
        "{:>9.4f}",
        s.time_s, s.position_m.x(), s.position_m.y(), s.position_m.z(), s.yaw_rad,
        s.yaw_held ? '*' : ' ', s.speed_mps, s.yaw_rate_radps, s.acceleration_mps2.x(),
        s.acceleration_mps2.y(), s.acceleration_mps2.z());
    if (height) out << "  " << Fixed(*s.body_height_m, 4);
    out << "\n";
    any_held = any_held || s.yaw_held;
  }
  if (any_held) out << "* yaw held: the speed is below the threshold (see client/README.md)\n";
}

struct SetpointsFlags {
  std::optional<std::string> from;
  PlanFlags plan;
  double t0_s = 0.0;
  double dt_s = 0.1;
  std::optional<int> steps;
  client::SetpointOptions options;
};

int RunSetpoints(const Context& ctx, const SetpointsFlags& flags) {
  if (auto error = flags.options.Validate()) {
    throw UsageError("--min-speed-for-yaw: " + error->message);
  }
  v1::PlanResponse response;
  if (flags.from) {
    FromJson(ReadFile(*flags.from), "\"" + *flags.from + "\"", &response);
  } else {
    const v1::PlanRequest request = PlanRequestFromFlags(flags.plan);
    if (!CallPlan(ctx, request, &response)) return kExitRpcError;
  }
  const auto trajectory = client::PolynomialTrajectory::FromPlanResponse(response);
  if (!trajectory) throw UsageError(trajectory.error().message);

  // Without --steps: from t0 to the end of the trajectory (at least one setpoint).
  const double span_steps = std::floor((trajectory->duration_s() - flags.t0_s) / flags.dt_s + 1e-9);
  const int steps = flags.steps.value_or(static_cast<int>(std::clamp(span_steps + 1, 1.0, 1e6)));
  const auto setpoints =
      client::ComputeSetpoints(*trajectory, flags.t0_s, flags.dt_s, steps, flags.options);
  if (!setpoints) throw UsageError(setpoints.error().message);
  if (ctx.json) {
    PrintJson(*ctx.out, *trajectory, setpoints.value());
  } else {
    PrintTable(*ctx.out, *trajectory, setpoints.value());
  }
  return kExitOk;
}

}  // namespace

void AddSetpointsCommand(CLI::App& app, const Context& ctx, Command* run) {
  auto [setpoints, flags] = AddCommand<SetpointsFlags>(
      app, "setpoints",
      "MPC setpoints from a saved `plan --json` output (--from) or a fresh plan (plan flags)", run,
      [&ctx](const SetpointsFlags& flags) { return RunSetpoints(ctx, flags); });
  CLI::Option* from = setpoints->add_option("--from", flags->from, "a saved PlanResponse in JSON")
                          ->type_name("PLAN.json");
  for (CLI::Option* option : AddPlanFlags(*setpoints, &flags->plan, /*required=*/false)) {
    from->excludes(option);
  }
  setpoints->add_option("--t0", flags->t0_s, "trajectory time of the first setpoint [s]")
      ->type_name("S")
      ->check(FiniteNumber())
      ->capture_default_str();
  setpoints->add_option("--dt", flags->dt_s, "time between setpoints [s]")
      ->type_name("S")
      ->check(PositiveNumber())
      ->capture_default_str();
  setpoints
      ->add_option("--steps", flags->steps,
                   "number of setpoints (default: from t0 to the end of the trajectory)")
      ->type_name("N")
      ->check(CLI::Range(1, 1000000).description(""));
  setpoints
      ->add_option("--min-speed-for-yaw", flags->options.min_speed_for_yaw_mps,
                   "below this horizontal speed the yaw is held")
      ->type_name("MPS")
      ->check(FiniteNumber())
      ->capture_default_str();
}

}  // namespace strata::cli
