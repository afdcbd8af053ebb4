#pragma once
// Swappable camera-pose solver used by tracking. The full 6-DoF solver is ORB-SLAM's motion-only BA
// (optimize::optimizePose); a rotation-given 3-DoF solver (Manhattan frame, thesis ch. 4) plugs in here.
#include <memory>
#include <string>
#include <vector>

#include "pslam/optimize/PoseOptimizer.h"

namespace pslam::tracking {

class PoseSolver {
 public:
  virtual ~PoseSolver() = default;
  virtual std::string name() const = 0;
  /// Refines T_cam_world from 3D-2D correspondences; outlier flags per observation in the result.
  virtual optimize::PoseOptimizationResult solve(const Eigen::Isometry3d& T_cam_world_initial,
                                                 const map::CameraIntrinsics& camera,
                                                 const std::vector<optimize::PoseObservation>& observations,
                                                 const std::vector<bool>& initialOutliers) const = 0;
};

/// 6-DoF motion-only BA: Huber 2.448 on level-whitened residuals, chi2 5.991 re-classification rounds.
class FullPoseSolver : public PoseSolver {
 public:
  explicit FullPoseSolver(optimize::PoseOptimizationParams params = {}) : params_(params) {}
  std::string name() const override { return "full6dof"; }
  optimize::PoseOptimizationResult solve(const Eigen::Isometry3d& T_cam_world_initial,
                                         const map::CameraIntrinsics& camera,
                                         const std::vector<optimize::PoseObservation>& observations,
                                         const std::vector<bool>& initialOutliers) const override {
    return optimize::optimizePose(T_cam_world_initial, camera, observations, params_, initialOutliers);
  }
  const optimize::PoseOptimizationParams& params() const { return params_; }

 private:
  optimize::PoseOptimizationParams params_;
};

}  // namespace pslam::tracking
