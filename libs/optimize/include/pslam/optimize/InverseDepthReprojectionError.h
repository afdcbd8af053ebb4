#pragma once
// Residual (b): reprojection of an inverse-depth map point (eq. 3.1) anchored in keyframe A, observed in
// keyframe B. Parameters: pose A [7] (T_A_world), pose B [7] (T_B_world), inverse depth rho [1]; the
// anchor's unit bearing b is data (fixed by the anchor keypoint, as in SVO/DSO).
//
//   P_A = b / rho,  P_B = T_B_world * T_A_world^-1 * P_A
// The projection is invariant to a positive scale of P_B, so it is evaluated on the homogeneous point
//   rho * P_B = R_B R_A^T (b - rho t_A) + rho t_B
// which stays finite for rho -> 0: a point at infinity still constrains the relative rotation (§3.2.1).
//
// Observation in the anchor itself: P_A = b / rho projects to pi(b) whatever rho and pose A are, so that
// residual is a constant (zero when b is the anchor keypoint's ray) with zero Jacobian. It carries no
// information and is not added to problems; anchorResidual() evaluates it for outlier checks.
#include <ceres/autodiff_cost_function.h>

#include "pslam/optimize/ReprojectionError.h"

namespace pslam::optimize {

/// Homogeneous point rho * P_B of an anchored point (doubles or Jets).
template <typename T>
Eigen::Matrix<T, 3, 1> anchoredPointInTarget(const T* poseA, const T* poseB, const T& rho,
                                             const Eigen::Vector3d& bearingA) {
  const Eigen::Map<const Eigen::Quaternion<T>> qA(poseA), qB(poseB);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tA(poseA + 4), tB(poseB + 4);
  const Eigen::Matrix<T, 3, 1> inWorldScaled = qA.conjugate() * (bearingA.cast<T>() - rho * tA);
  return qB * inWorldScaled + rho * tB;
}

struct InverseDepthReprojectionError {
  InverseDepthReprojectionError(const Eigen::Vector3d& bearingA, const Eigen::Vector2d& observedB, double invSigma2,
                                const geometry::PinholeCamera& cameraB)
      : bearingA_(bearingA), observed_(observedB), sqrtInformation_(std::sqrt(invSigma2)), camera_(cameraB) {}

  template <typename T>
  bool operator()(const T* poseA, const T* poseB, const T* rho, T* residual) const {
    whitenedReprojection(anchoredPointInTarget(poseA, poseB, rho[0], bearingA_), camera_, observed_,
                         sqrtInformation_, residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& bearingA, const Eigen::Vector2d& observedB,
                                     double invSigma2, const geometry::PinholeCamera& cameraB) {
    return new ceres::AutoDiffCostFunction<InverseDepthReprojectionError, 2, kPoseSize, kPoseSize, 1>(
        new InverseDepthReprojectionError(bearingA, observedB, invSigma2, cameraB));
  }

 private:
  Eigen::Vector3d bearingA_;
  Eigen::Vector2d observed_;
  double sqrtInformation_;
  geometry::PinholeCamera camera_;
};

/// The constant whitened residual of the observation in the anchor keyframe itself (see above).
inline Eigen::Vector2d anchorResidual(const Eigen::Vector3d& bearingA, const Eigen::Vector2d& observedA,
                                      double invSigma2, const geometry::PinholeCamera& cameraA) {
  Eigen::Vector2d r;
  whitenedReprojection<double>(bearingA, cameraA, observedA, std::sqrt(invSigma2), r.data());
  return r;
}

}  // namespace pslam::optimize
