#include "strata/client/replan.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "strata/client/polynomial_trajectory.hpp"

namespace strata::client {
namespace {

void SetVector(const Eigen::Vector3d& v, v1::Vector3* message) {
  message->set_x(v.x());
  message->set_y(v.y());
  message->set_z(v.z());
}

}  // namespace

Expected<v1::PlanRequest> MakeReplanRequest(const v1::PlanRequest& request,
                                            const v1::PlanResponse& followed, double elapsed_s) {
  if (!std::isfinite(elapsed_s)) {
    return ClientError{"elapsed_s is " + std::to_string(elapsed_s) + "; it must be finite"};
  }
  Expected<PolynomialTrajectory> trajectory = PolynomialTrajectory::FromPlanResponse(followed);
  if (!trajectory.ok()) return trajectory.error();
  const double t = std::clamp(elapsed_s, 0.0, trajectory->duration_s());
  v1::PlanRequest replan = request;
  v1::RobotState* start = replan.mutable_start();
  start->Clear();
  SetVector(trajectory->PositionAt(t), start->mutable_position_m());
  SetVector(trajectory->VelocityAt(t), start->mutable_velocity_mps());
  SetVector(trajectory->AccelerationAt(t), start->mutable_acceleration_mps2());
  *replan.mutable_warm_start()->mutable_trajectory() = followed.trajectory();
  replan.mutable_warm_start()->set_elapsed_s(t);
  return replan;
}

}  // namespace strata::client
