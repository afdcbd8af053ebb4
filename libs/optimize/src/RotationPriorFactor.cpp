#include "pslam/optimize/RotationPriorFactor.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/AnalyticJacobians.h"
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

void requireRotationMeasurement(const char* who, const Eigen::Matrix3d& R, double sigmaRad) {
  require(sigmaRad > 0.0 && std::isfinite(sigmaRad), who, "sigma must be a positive number");
  require(R.allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0,
          who, "the measurement is not a rotation matrix");
}

/// J_l^-1(phi) of SO(3): Log(exp(omega) exp(phi)) = phi + J_l^-1(phi) omega + O(|omega|^2).
Eigen::Matrix3d inverseLeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d W = detail::skew(phi);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 12.0;
  const double c = 1.0 / (theta * theta) - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  return Eigen::Matrix3d::Identity() - 0.5 * W + c * W * W;
}

}  // namespace

RotationPriorFactor::RotationPriorFactor(map::KeyFrameId keyframe, const Eigen::Matrix3d& R_cam_world, double sigmaRad)
    : keyframe_(keyframe), invSigma_(1.0 / sigmaRad) {
  requireRotationMeasurement("RotationPriorFactor", R_cam_world, sigmaRad);
  q_meas_ = Eigen::Quaterniond(R_cam_world).normalized();
}

RotationPosePriorFactor::RotationPosePriorFactor(const Eigen::Matrix3d& R_cam_world, double sigmaRad)
    : invSigma_(1.0 / sigmaRad) {
  requireRotationMeasurement("RotationPosePriorFactor", R_cam_world, sigmaRad);
  // Re-orthonormalized so that the residual is exactly zero at the measurement.
  R_meas_ = Eigen::Quaterniond(R_cam_world).normalized().toRotationMatrix();
}

bool RotationPosePriorFactor::evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                                       Eigen::MatrixXd* jacobian) const {
  const Eigen::AngleAxisd e(T_cam_world.linear() * R_meas_.transpose());
  const Eigen::Vector3d phi = e.angle() * e.axis();
  residual = invSigma_ * phi;
  if (jacobian) {
    jacobian->setZero(3, 6);
    jacobian->leftCols<3>() = invSigma_ * inverseLeftJacobianSO3(phi);
  }
  return true;
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
