#include "pslam/optimize/RotationPriorFactor.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/PoseParameterization.h"

namespace pslam::optimize {

namespace {

struct RotationPriorCost {
  Eigen::Quaterniond q_meas;
  double invSigma;

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    // E = R(q) R_meas^T as a quaternion; the shorter of +-E so the angle stays within [0, pi].
    Eigen::Quaternion<T> e = q * q_meas.conjugate().cast<T>();
    const T sign = e.w() < T(0) ? T(-1) : T(1);
    const T wxyz[4] = {sign * e.w(), sign * e.x(), sign * e.y(), sign * e.z()};
    ceres::QuaternionToAngleAxis(wxyz, residual);
    // The pose block's quaternion is unit on the manifold but not under finite-difference probes; the angle of a
    // scaled quaternion is unchanged, which is what QuaternionToAngleAxis computes.
    for (int k = 0; k < 3; ++k) residual[k] *= T(invSigma);
    return true;
  }
};

}  // namespace

RotationPriorFactor::RotationPriorFactor(map::KeyFrameId keyframe, const Eigen::Matrix3d& R_cam_world, double sigmaRad)
    : keyframe_(keyframe), invSigma_(1.0 / sigmaRad) {
  require(sigmaRad > 0.0 && std::isfinite(sigmaRad), "RotationPriorFactor", "sigma must be a positive number");
  require(R_cam_world.allFinite() && (R_cam_world.transpose() * R_cam_world - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
              R_cam_world.determinant() > 0.0,
          "RotationPriorFactor", "the measurement is not a rotation matrix");
  q_meas_ = Eigen::Quaterniond(R_cam_world).normalized();
}

ceres::CostFunction* RotationPriorFactor::newCostFunction() const {
  return new ceres::AutoDiffCostFunction<RotationPriorCost, 3, kPoseSize>(new RotationPriorCost{q_meas_, invSigma_});
}

Eigen::Vector3d RotationPriorFactor::residual(const double* pose) const {
  Eigen::Vector3d r;
  RotationPriorCost{q_meas_, invSigma_}(pose, r.data());
  return r;
}

}  // namespace pslam::optimize
