#include "pslam/optimize/PoseOptimizer.h"

#include <memory>

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/AnalyticJacobians.h"

namespace pslam::optimize {

namespace {
// Chi-square of one correspondence (whitened squared reprojection error) and whether it is in front.
double chi2At(const PoseParameters& pose, const map::CameraIntrinsics& cam, const PoseObservation& o,
              bool& inFront) {
  const Eigen::Vector3d pc = transformPoint(pose.data(), Eigen::Vector3d(o.p_world));
  inFront = pc.z() > 0.0;
  Eigen::Vector2d r;
  whitenedReprojection<double>(pc, cam, o.pixel, std::sqrt(o.invSigma2), r.data());
  return r.squaredNorm();
}
}  // namespace

PoseOptimizationResult optimizePose(const Eigen::Isometry3d& T_cam_world_initial, const map::CameraIntrinsics& camera,
                                    const std::vector<PoseObservation>& observations,
                                    const PoseOptimizationParams& params, const std::vector<bool>& initialOutliers) {
  params.check();
  camera.check("optimizePose: camera");
  require(T_cam_world_initial.matrix().allFinite(), "optimizePose", "initial pose has NaN/Inf entries");
  require(initialOutliers.empty() || initialOutliers.size() == observations.size(), "optimizePose",
          "initialOutliers must be empty or one flag per observation");
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const PoseObservation& o = observations[i];
    require(o.p_world.allFinite() && o.pixel.allFinite() && std::isfinite(o.invSigma2) && o.invSigma2 > 0.0,
            "optimizePose", "observation " + std::to_string(i) + " has a NaN/Inf value or non-positive weight");
  }

  PoseOptimizationResult result;
  result.T_cam_world = T_cam_world_initial;
  result.outlier = initialOutliers.empty() ? std::vector<bool>(observations.size(), false) : initialOutliers;
  if (static_cast<int>(observations.size()) < params.minCorrespondences) {
    result.inliers = 0;
    return result;
  }

  const PoseParameters initial = toPoseParameters(T_cam_world_initial);
  PoseParameters pose = initial;
  PoseParameters solved = initial;  // the estimate of the last round actually solved
  ceres::HuberLoss huber(params.huberDelta);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = params.iterationsPerRound;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;

  for (int round = 0; round < params.rounds; ++round) {
    // ORB-SLAM restarts every round from the initial estimate, only the inlier set changes.
    pose = initial;
    ceres::Problem::Options problemOptions;
    problemOptions.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problemOptions.manifold_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problemOptions);
    ceres::LossFunction* loss = round < params.robustRounds ? &huber : nullptr;
    int used = 0;
    for (std::size_t i = 0; i < observations.size(); ++i) {
      if (result.outlier[i]) continue;
      const PoseObservation& o = observations[i];
      problem.AddResidualBlock(new PoseOnlyReprojectionCost(o.p_world, o.pixel, o.invSigma2, camera), loss,
                               pose.data());
      ++used;
    }
    if (used < params.minCorrespondences) break;
    problem.SetManifold(pose.data(), new PoseManifold);
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    result.roundsRun = round + 1;
    solved = pose;

    int inliers = 0;
    for (std::size_t i = 0; i < observations.size(); ++i) {
      bool inFront = false;
      const double chi2 = chi2At(pose, camera, observations[i], inFront);
      result.outlier[i] = !(chi2 <= params.chi2Threshold) || !inFront;
      inliers += result.outlier[i] ? 0 : 1;
    }
    if (inliers < params.minInliersToContinue) break;
  }

  // Classification and chi-square at the returned pose.
  result.T_cam_world = fromPoseParameters(solved.data());
  result.inliers = 0;
  result.finalChi2Sum = 0.0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    bool inFront = false;
    const double chi2 = chi2At(solved, camera, observations[i], inFront);
    result.outlier[i] = !(chi2 <= params.chi2Threshold) || !inFront;
    if (result.outlier[i]) continue;
    ++result.inliers;
    result.finalChi2Sum += chi2;
  }
  return result;
}

}  // namespace pslam::optimize
