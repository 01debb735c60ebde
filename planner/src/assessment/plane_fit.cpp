#include "strata/assessment/plane_fit.hpp"

#include <algorithm>
#include <cmath>

#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_plane.h>
#include <Eigen/Eigenvalues>

#include "pcl_quiet_internal.hpp"

// PCL's RANSAC allocates Eigen buffers inside Debian's libpcl (plain malloc, no sanitiser)
// that this file frees: both sides must agree on how Eigen allocates. Under ASan the build
// sets EIGEN_MALLOC_ALREADY_ALIGNED=1 (CMakeLists.txt, STRATA_SANITIZE), which is only right
// where malloc's alignment covers Eigen's: glibc's 16 bytes, Eigen's default 16 (no AVX).
static_assert(EIGEN_MALLOC_ALREADY_ALIGNED == 1 && EIGEN_DEFAULT_ALIGN_BYTES == 16,
              "Eigen would allocate otherwise than Debian's PCL, built against plain malloc");

namespace strata {
namespace {

// Least-squares plane through the points selected by `take`: the normal is the eigenvector of
// the covariance with the smallest eigenvalue. Returns false when the points are collinear.
// With `weights` (one per point, > 0) the centroid and covariance are weighted.
template <typename Take>
bool LeastSquaresPlane(std::span<const Eigen::Vector3f> points, std::span<const float> weights,
                       Take take, PlaneFit* fit) {
  const auto weight = [&](std::size_t i) { return weights.empty() ? 1.0 : double{weights[i]}; };
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double total = 0;
  int count = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!take(i)) continue;
    sum += weight(i) * points[i].cast<double>();
    total += weight(i);
    ++count;
  }
  if (count < 3 || !(total > 0)) return false;
  const Eigen::Vector3d centroid = sum / total;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!take(i)) continue;
    const Eigen::Vector3d d = points[i].cast<double>() - centroid;
    covariance += weight(i) * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector3d eigenvalues = solver.eigenvalues();
  // Collinear (or coincident) points: the two largest spreads dominate a zero middle one.
  if (eigenvalues(1) <= 1e-12 * std::max(1.0, eigenvalues(2))) return false;
  Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
  if (normal.z() < 0) normal = -normal;
  fit->center_m = centroid;
  fit->normal = normal;
  // |n_z| folds φ and π − φ together, as the paper asks.
  fit->tilt_rad = std::acos(std::clamp(normal.z(), 0.0, 1.0));
  fit->inlier_count = count;
  return true;
}

double MaxResidual(std::span<const Eigen::Vector3f> points, const PlaneFit& fit) {
  double worst = 0.0;
  for (const auto& p : points) {
    worst = std::max(worst, std::abs(fit.normal.dot(p.cast<double>() - fit.center_m)));
  }
  return worst;
}

}  // namespace

struct LocalPlaneFitter::Ransac {
  std::shared_ptr<pcl::PointCloud<pcl::PointXYZ>> cloud =
      std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl::Indices inliers;
  std::vector<std::uint8_t> is_inlier;
};

LocalPlaneFitter::LocalPlaneFitter(double inlier_distance_m, int ransac_iterations)
    : inlier_distance_m_(inlier_distance_m),
      ransac_iterations_(ransac_iterations),
      ransac_(std::make_unique<Ransac>()) {
  internal::SilencePclConsole();
}

LocalPlaneFitter::~LocalPlaneFitter() = default;

PlaneFit LocalPlaneFitter::Fit(std::span<const Eigen::Vector3f> points,
                               std::span<const float> weights) {
  PlaneFit fit;
  if (points.size() < 3 || (!weights.empty() && weights.size() != points.size())) return fit;
  const auto all = [](std::size_t) { return true; };
  if (!LeastSquaresPlane(points, weights, all, &fit)) {
    fit.inlier_count = 0;
    return fit;
  }
  if (MaxResidual(points, fit) <= inlier_distance_m_) return fit;

  Ransac& r = *ransac_;
  r.cloud->resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) (*r.cloud)[i].getVector3fMap() = points[i];
  // A fresh model per patch: PCL seeds its sampler with a fixed value at construction, so every
  // patch gets the same random sequence whichever thread fits it, and the map is reproducible.
  auto model = std::make_shared<pcl::SampleConsensusModelPlane<pcl::PointXYZ>>(r.cloud);
  pcl::RandomSampleConsensus<pcl::PointXYZ> sac(model, inlier_distance_m_);
  sac.setMaxIterations(ransac_iterations_);
  if (!sac.computeModel()) return fit;  // Keep the all-points fit.
  sac.getInliers(r.inliers);
  r.is_inlier.assign(points.size(), 0);
  for (const auto i : r.inliers) r.is_inlier[i] = 1;
  PlaneFit refined;
  if (LeastSquaresPlane(
          points, weights, [&](std::size_t i) { return r.is_inlier[i] != 0; }, &refined)) {
    return refined;
  }
  return fit;
}

PlaneFit FitLocalPlane(std::span<const Eigen::Vector3f> points, double inlier_distance_m,
                       int ransac_iterations) {
  return LocalPlaneFitter(inlier_distance_m, ransac_iterations).Fit(points);
}

}  // namespace strata
