#pragma once
// Residual (a): reprojection of a world point into a camera pose, whitened by the keypoint level
// (covariance scaling of §3.2.3 / eq. 2.96: r = (1/sigma_l) * (pi(T_cam_world * X) - x_observed), so that
// |r|^2 is the chi-square value tested against 5.991 (Table 3.2)).
//   ReprojectionError          parameters: pose [7], world point [3]      (full bundle adjustment)
//   PoseOnlyReprojectionError  parameters: pose [7]; the point is data    (motion-only, optimizePose)
#include <ceres/autodiff_cost_function.h>

#include "pslam/map/Types.h"
#include "pslam/optimize/PoseParameterization.h"

namespace pslam::optimize {

/// Whitened pinhole reprojection residual of a camera-frame point (shared by all residuals).
template <typename T>
void whitenedReprojection(const Eigen::Matrix<T, 3, 1>& p_cam, const geometry::PinholeCamera& cam,
                          const Eigen::Vector2d& observed, double sqrtInformation, T* residual) {
  residual[0] = T(sqrtInformation) * (T(cam.fx) * p_cam.x() / p_cam.z() + T(cam.cx) - T(observed.x()));
  residual[1] = T(sqrtInformation) * (T(cam.fy) * p_cam.y() / p_cam.z() + T(cam.cy) - T(observed.y()));
}

struct ReprojectionError {
  ReprojectionError(const Eigen::Vector2d& observed, double invSigma2, const geometry::PinholeCamera& camera)
      : observed_(observed), sqrtInformation_(std::sqrt(invSigma2)), camera_(camera) {}

  template <typename T>
  bool operator()(const T* pose, const T* point, T* residual) const {
    const Eigen::Matrix<T, 3, 1> p_world(point[0], point[1], point[2]);
    whitenedReprojection(transformPoint(pose, p_world), camera_, observed_, sqrtInformation_, residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector2d& observed, double invSigma2,
                                     const geometry::PinholeCamera& camera) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, kPoseSize, 3>(
        new ReprojectionError(observed, invSigma2, camera));
  }

 private:
  Eigen::Vector2d observed_;
  double sqrtInformation_;
  geometry::PinholeCamera camera_;
};

struct PoseOnlyReprojectionError {
  PoseOnlyReprojectionError(const Eigen::Vector3d& p_world, const Eigen::Vector2d& observed, double invSigma2,
                            const geometry::PinholeCamera& camera)
      : p_world_(p_world), observed_(observed), sqrtInformation_(std::sqrt(invSigma2)), camera_(camera) {}

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    whitenedReprojection(transformPoint(pose, Eigen::Matrix<T, 3, 1>(p_world_.cast<T>())), camera_, observed_,
                         sqrtInformation_, residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& p_world, const Eigen::Vector2d& observed,
                                     double invSigma2, const geometry::PinholeCamera& camera) {
    return new ceres::AutoDiffCostFunction<PoseOnlyReprojectionError, 2, kPoseSize>(
        new PoseOnlyReprojectionError(p_world, observed, invSigma2, camera));
  }

 private:
  Eigen::Vector3d p_world_;
  Eigen::Vector2d observed_;
  double sqrtInformation_;
  geometry::PinholeCamera camera_;
};

}  // namespace pslam::optimize
