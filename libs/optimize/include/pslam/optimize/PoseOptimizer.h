#pragma once
// Motion-only bundle adjustment of one camera against known world points (tracking), following ORB-SLAM's
// PoseOptimization: rounds of a few Levenberg-Marquardt iterations; after each round every correspondence
// (including those rejected earlier) is re-classified by its chi-square against chi2Threshold, and the next
// round starts again from the initial pose using the inliers only. Huber loss in the first robustRounds.
// The solver is Levenberg-Marquardt on the 6x6 normal equations in the left-perturbation tangent space of
// T_cam_world (as g2o's SE3 vertex in ORB-SLAM), not a Ceres problem: 6 unknowns do not pay for Ceres'
// per-problem set-up (measured 2.6 -> ~0.5 ms per call at 640x480, doc/slam.md).
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "pslam/optimize/PoseFactor.h"

#include "pslam/map/Types.h"
#include "pslam/optimize/Params.h"

namespace pslam::optimize {

struct PoseObservation {
  Eigen::Vector3d p_world;   ///< the matched map point
  Eigen::Vector2d pixel;     ///< undistorted keypoint position
  double invSigma2 = 1.0;    ///< 1 / sigma^2 of the keypoint's pyramid level
};

struct PoseOptimizationResult {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  int inliers = 0;
  std::vector<bool> outlier;  ///< per observation, after the last round
  std::vector<bool> factorOutlier;  ///< per extra factor (PoseFactor), after the last round
  int roundsRun = 0;
  double finalChi2Sum = 0.0;  ///< sum of the inliers' chi-square values at the returned pose
};

/// Whitened reprojection residual sqrt(invSigma2) * (pi(T p_world) - pixel) of one observation and, when
/// `jacobian` is given, its derivative w.r.t. xi = (omega, v) of the left perturbation T <- Exp(xi) T
/// (retractPoseLeft). Returns false when the point is not in front of the camera.
bool poseOnlyResidual(const Eigen::Isometry3d& T_cam_world, const geometry::PinholeCamera& camera,
                      const PoseObservation& observation, Eigen::Vector2d& residual,
                      Eigen::Matrix<double, 2, 6>* jacobian);
/// T <- Exp(xi) T with the rotation exp(omega) (angle-axis) and translation v: a retraction whose derivative
/// at xi = 0 is the one poseOnlyResidual's Jacobian assumes.
Eigen::Isometry3d retractPoseLeft(const Eigen::Matrix<double, 6, 1>& xi, const Eigen::Isometry3d& T_cam_world);

/// Which degrees of freedom of the pose are optimized.
enum class PoseFreedom {
  Full6Dof,        ///< rotation and translation
  TranslationOnly  ///< the rotation of the initial pose is kept (rotation known, thesis §4.4.2 / eq. 4.2)
};

/// Optimizes T_cam_world starting from `T_cam_world_initial`. Observations marked in `initialOutliers`
/// (empty = none) start excluded but are re-checked after the first round. `factors` are observations of
/// other landmark kinds (PoseFactor.h) optimized jointly; they start as inliers and are classified with their
/// own chi-square threshold. Throws pslam::Error on non-finite input or a size mismatch.
PoseOptimizationResult optimizePose(const Eigen::Isometry3d& T_cam_world_initial, const geometry::PinholeCamera& camera,
                                    const std::vector<PoseObservation>& observations,
                                    const PoseOptimizationParams& params = {},
                                    const std::vector<bool>& initialOutliers = {},
                                    const std::vector<std::shared_ptr<const PoseFactor>>& factors = {},
                                    PoseFreedom freedom = PoseFreedom::Full6Dof);

}  // namespace pslam::optimize
