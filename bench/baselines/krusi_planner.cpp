#include "baselines/krusi_planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateSampler.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

namespace strata::baselines {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using Clock = std::chrono::steady_clock;

Eigen::Vector3d ToVector(const ob::State* state) {
  const auto* s = state->as<ob::RealVectorStateSpace::StateType>();
  return {s->values[0], s->values[1], s->values[2]};
}

void FromVector(const Eigen::Vector3d& p, ob::State* state) {
  auto* s = state->as<ob::RealVectorStateSpace::StateType>();
  for (int a = 0; a < 3; ++a) s->values[a] = p(a);
}

// Samples states on the cloud: a random point, moved by up to half the point spacing
// horizontally, lifted by the reference height. Most of them lie on some surface, so the
// planner does not waste its time on states in the air (Krüsi et al. sample the map's points).
class CloudStateSampler : public ob::StateSampler {
 public:
  CloudStateSampler(const ob::StateSpace* space, const KrusiTerrain& terrain, double spacing_m)
      : ob::StateSampler(space), terrain_(terrain), jitter_m_(0.5 * spacing_m) {}

  void sampleUniform(ob::State* state) override {
    const int n = static_cast<int>(terrain_.search().size());
    const Eigen::Vector3f& q = terrain_.search().point(rng_.uniformInt(0, n - 1));
    FromVector({q.x() + rng_.uniformReal(-jitter_m_, jitter_m_),
                q.y() + rng_.uniformReal(-jitter_m_, jitter_m_),
                q.z() + terrain_.robot().reference_height_m},
               state);
    space_->enforceBounds(state);
  }
  void sampleUniformNear(ob::State* state, const ob::State* near, double distance) override {
    const Eigen::Vector3d c = ToVector(near);
    FromVector({c.x() + rng_.uniformReal(-distance, distance),
                c.y() + rng_.uniformReal(-distance, distance), c.z()},
               state);
    space_->enforceBounds(state);
  }
  void sampleGaussian(ob::State* state, const ob::State* mean, double std_dev) override {
    const Eigen::Vector3d c = ToVector(mean);
    FromVector({rng_.gaussian(c.x(), std_dev), rng_.gaussian(c.y(), std_dev), c.z()}, state);
    space_->enforceBounds(state);
  }

 private:
  const KrusiTerrain& terrain_;
  double jitter_m_;
};

// Checks motions on the cloud with KrusiTerrain::MotionValid.
class SurfaceMotionValidator : public ob::MotionValidator {
 public:
  SurfaceMotionValidator(ob::SpaceInformation* si, const KrusiTerrain& terrain)
      : ob::MotionValidator(si), terrain_(terrain) {}

  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const bool ok = terrain_.MotionValid(ToVector(s1), ToVector(s2));
    ok ? ++valid_ : ++invalid_;
    return ok;
  }
  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    double fraction = 0;
    const bool ok = terrain_.MotionValid(ToVector(s1), ToVector(s2), &fraction);
    if (!ok) {
      last_valid.second = fraction;
      if (last_valid.first != nullptr)
        si_->getStateSpace()->interpolate(s1, s2, fraction, last_valid.first);
    }
    ok ? ++valid_ : ++invalid_;
    return ok;
  }

 private:
  const KrusiTerrain& terrain_;
};

}  // namespace

struct KrusiPlanner::Impl {
  KrusiParams params;
  BaselineRobot robot;
  std::unique_ptr<CloudSearch> search;
  std::unique_ptr<KrusiTerrain> terrain;
  double spacing_m = 0;
  double assessment_s = 0;
  Eigen::AlignedBox3d bounds;

  // The query point itself when it is valid, else the nearest valid state above a cloud point
  // within the snap tolerance.
  bool Snap(const Eigen::Vector3d& p, Eigen::Vector3d* snapped, double* distance_m) const {
    if (terrain->GroundUnder(p)) {
      *snapped = p;
      *distance_m = 0;
      return true;
    }
    const Eigen::Vector3d lift(0, 0, robot.reference_height_m);
    std::vector<int> indices;
    std::vector<float> squared;
    search->Nearest((p - lift).cast<float>(), params.snap_candidates, &indices, &squared);
    for (const int i : indices) {
      const Eigen::Vector3d candidate = search->point(i).cast<double>() + lift;
      if ((candidate - p).norm() > params.snap_tolerance_m) break;
      if (const auto ground = terrain->GroundUnder(candidate)) {
        *snapped = {candidate.x(), candidate.y(), *ground + robot.reference_height_m};
        *distance_m = (*snapped - p).norm();
        return true;
      }
    }
    return false;
  }
};

KrusiPlanner::KrusiPlanner(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
KrusiPlanner::~KrusiPlanner() = default;
double KrusiPlanner::assessment_s() const { return impl_->assessment_s; }
double KrusiPlanner::point_spacing_m() const { return impl_->spacing_m; }

void KrusiPlanner::SeedRandom(std::uint32_t seed) { ompl::RNG::setSeed(seed); }

Expected<std::unique_ptr<KrusiPlanner>> KrusiPlanner::Build(const PointCloud& cloud,
                                                            const BaselineRobot& robot,
                                                            const KrusiParams& params) {
  if (cloud.empty()) return Error{ErrorCode::kInvalidInput, "the cloud is empty"};
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);  // OMPL prints every plan at LOG_INFO.
  auto impl = std::make_unique<Impl>();
  impl->params = params;
  impl->robot = robot;
  const auto start = Clock::now();
  impl->search = std::make_unique<CloudSearch>(cloud);
  impl->assessment_s = std::chrono::duration<double>(Clock::now() - start).count();
  // Not part of t_a: a fixed number for a given cloud that the method's users would configure.
  impl->spacing_m = impl->search->MedianSpacing();
  impl->terrain =
      std::make_unique<KrusiTerrain>(*impl->search, robot, params.terrain, impl->spacing_m);
  for (const Eigen::Vector3f& p : cloud) impl->bounds.extend(p.cast<double>());
  return std::unique_ptr<KrusiPlanner>(new KrusiPlanner(std::move(impl)));
}

Expected<BaselinePath> KrusiPlanner::Plan(const Eigen::Vector3d& start_m,
                                          const Eigen::Vector3d& goal_m,
                                          double time_limit_s) const {
  const auto begin = Clock::now();
  const Impl& k = *impl_;
  BaselinePath result;
  Eigen::Vector3d start, goal;
  if (!k.Snap(start_m, &start, &result.start_snap_m)) {
    return Error{
        ErrorCode::kStartOffGround,
        "no valid state within " + std::to_string(k.params.snap_tolerance_m) + " m of the start"};
  }
  if (!k.Snap(goal_m, &goal, &result.goal_snap_m)) {
    return Error{
        ErrorCode::kGoalOffGround,
        "no valid state within " + std::to_string(k.params.snap_tolerance_m) + " m of the goal"};
  }

  auto space = std::make_shared<ob::RealVectorStateSpace>(3);
  ob::RealVectorBounds bounds(3);
  for (int a = 0; a < 3; ++a) {
    bounds.setLow(a, k.bounds.min()(a) - 1.0);
    bounds.setHigh(a, k.bounds.max()(a) + 1.0 + k.robot.reference_height_m);
  }
  space->setBounds(bounds);
  const KrusiTerrain& terrain = *k.terrain;
  const double spacing = k.spacing_m;
  space->setStateSamplerAllocator([&terrain, spacing](const ob::StateSpace* s) {
    return std::make_shared<CloudStateSampler>(s, terrain, spacing);
  });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(
      [&terrain](const ob::State* s) { return terrain.GroundUnder(ToVector(s)).has_value(); });
  si->setMotionValidator(std::make_shared<SurfaceMotionValidator>(si.get(), terrain));
  si->setup();

  ob::ScopedState<> start_state(space), goal_state(space);
  FromVector(start, start_state.get());
  FromVector(goal, goal_state.get());
  auto problem = std::make_shared<ob::ProblemDefinition>(si);
  problem->setStartAndGoalStates(start_state, goal_state, 1e-6);

  og::RRTConnect planner(si);
  planner.setRange(k.params.range_m);
  planner.setProblemDefinition(problem);
  planner.setup();
  const double elapsed = std::chrono::duration<double>(Clock::now() - begin).count();
  const double refine = std::min(k.params.refine_time_s, 0.5 * time_limit_s);
  const double search_budget = std::max(0.0, time_limit_s - refine - elapsed);
  const ob::PlannerStatus status =
      planner.solve(ob::timedPlannerTerminationCondition(search_budget));
  if (status != ob::PlannerStatus::EXACT_SOLUTION) {
    return Error{ErrorCode::kDeadlineExceeded,
                 "RRT-Connect found no path in " + std::to_string(search_budget) + " s"};
  }
  auto* path = problem->getSolutionPath()->as<og::PathGeometric>();
  og::PathSimplifier simplifier(si);
  simplifier.simplify(*path, refine);
  // States carry z only to select the level; the path lies at ground + reference height.
  for (std::size_t i = 0; i < path->getStateCount(); ++i) {
    Eigen::Vector3d p = ToVector(path->getState(i));
    if (const auto ground = terrain.GroundUnder(p)) p.z() = *ground + k.robot.reference_height_m;
    result.points_m.push_back(p);
  }
  return result;
}

}  // namespace strata::baselines
