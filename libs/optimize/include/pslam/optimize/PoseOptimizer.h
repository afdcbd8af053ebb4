#pragma once
// Motion-only bundle adjustment of one camera against known world points (tracking), following ORB-SLAM's
// PoseOptimization: rounds of a few Levenberg-Marquardt iterations; after each round every correspondence
// (including those rejected earlier) is re-classified by its chi-square against chi2Threshold, and the next
// round starts again from the initial pose using the inliers only. Huber loss in the first robustRounds.
#include <vector>

#include <Eigen/Geometry>

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
  int roundsRun = 0;
  double finalChi2Sum = 0.0;  ///< sum of the inliers' chi-square values at the returned pose
};

/// Optimizes T_cam_world starting from `T_cam_world_initial`. Observations marked in `initialOutliers`
/// (empty = none) start excluded but are re-checked after the first round. Throws pslam::Error on
/// non-finite input or a size mismatch.
PoseOptimizationResult optimizePose(const Eigen::Isometry3d& T_cam_world_initial, const map::CameraIntrinsics& camera,
                                    const std::vector<PoseObservation>& observations,
                                    const PoseOptimizationParams& params = {},
                                    const std::vector<bool>& initialOutliers = {});

}  // namespace pslam::optimize
