#pragma once
// Hand-derived Jacobians of the two residuals used in the hot loops (motion-only optimization and bundle
// adjustment), w.r.t. the ambient pose parameters [qx qy qz qw tx ty tz]; Ceres maps them to the tangent
// space through PoseManifold. They are verified against the autodiff functors and ceres::GradientChecker
// in test_residuals.cpp; autodiff is ~3x slower on these residuals (bench_optimize).
//
// Rotation as Eigen evaluates q * v (valid for any q, equal to R(q) v for |q| = 1):
//   f(q, v) = v + 2w (u x v) + 2 u x (u x v),   q = (u, w)
//   df/dw = 2 (u x v)
//   df/du = -2w [v]x + 2 (u v^T + (u.v) I - 2 v u^T)
//   df/dv = M(q) = I + 2w [u]x + 2 [u]x^2
#include <ceres/sized_cost_function.h>

#include "pslam/optimize/InverseDepthReprojectionError.h"

namespace pslam::optimize {

namespace detail {

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

/// M(q) of the header comment (the rotation matrix for a unit quaternion).
inline Eigen::Matrix3d rotationOperator(const Eigen::Vector3d& u, double w) {
  const Eigen::Matrix3d U = skew(u);
  return Eigen::Matrix3d::Identity() + 2.0 * w * U + 2.0 * U * U;
}

/// d(q * v)/d[qx qy qz qw], 3 x 4.
inline Eigen::Matrix<double, 3, 4> rotationJacobian(const Eigen::Vector3d& u, double w, const Eigen::Vector3d& v) {
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() = -2.0 * w * skew(v) +
                    2.0 * (u * v.transpose() + u.dot(v) * Eigen::Matrix3d::Identity() - 2.0 * v * u.transpose());
  J.col(3) = 2.0 * u.cross(v);
  return J;
}

/// Whitened pinhole projection and its 2 x 3 Jacobian w.r.t. the (homogeneous) camera point.
inline void projectWhitened(const Eigen::Vector3d& p, const geometry::PinholeCamera& cam, const Eigen::Vector2d& obs,
                            double s, double* residual, Eigen::Matrix<double, 2, 3>& J) {
  const double iz = 1.0 / p.z();
  residual[0] = s * (cam.fx * p.x() * iz + cam.cx - obs.x());
  residual[1] = s * (cam.fy * p.y() * iz + cam.cy - obs.y());
  J << s * cam.fx * iz, 0.0, -s * cam.fx * p.x() * iz * iz, 0.0, s * cam.fy * iz, -s * cam.fy * p.y() * iz * iz;
}

}  // namespace detail

/// PoseOnlyReprojectionError with analytic Jacobian (parameters: pose [7]).
class PoseOnlyReprojectionCost final : public ceres::SizedCostFunction<2, kPoseSize> {
 public:
  PoseOnlyReprojectionCost(const Eigen::Vector3d& p_world, const Eigen::Vector2d& observed, double invSigma2,
                           const geometry::PinholeCamera& camera)
      : p_world_(p_world), observed_(observed), sqrtInformation_(std::sqrt(invSigma2)), camera_(camera) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* pose = parameters[0];
    const Eigen::Vector3d u(pose[0], pose[1], pose[2]);
    const double w = pose[3];
    const Eigen::Vector3d pc = detail::rotationOperator(u, w) * p_world_ + Eigen::Vector3d(pose[4], pose[5], pose[6]);
    Eigen::Matrix<double, 2, 3> Jp;
    detail::projectWhitened(pc, camera_, observed_, sqrtInformation_, residuals, Jp);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 2, kPoseSize, Eigen::RowMajor>> J(jacobians[0]);
      J.leftCols<4>() = Jp * detail::rotationJacobian(u, w, p_world_);
      J.rightCols<3>() = Jp;
    }
    return true;
  }

 private:
  Eigen::Vector3d p_world_;
  Eigen::Vector2d observed_;
  double sqrtInformation_;
  geometry::PinholeCamera camera_;
};

/// InverseDepthReprojectionError with analytic Jacobians (parameters: pose A [7], pose B [7], rho [1]).
///   m = conj(qA) * (b - rho tA),   h = qB * m + rho tB,   r = whitened pi(h)
class InverseDepthReprojectionCost final : public ceres::SizedCostFunction<2, kPoseSize, kPoseSize, 1> {
 public:
  InverseDepthReprojectionCost(const Eigen::Vector3d& bearingA, const Eigen::Vector2d& observedB, double invSigma2,
                               const geometry::PinholeCamera& cameraB)
      : bearingA_(bearingA), observed_(observedB), sqrtInformation_(std::sqrt(invSigma2)), camera_(cameraB) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* poseA = parameters[0];
    const double* poseB = parameters[1];
    const double rho = parameters[2][0];
    const Eigen::Vector3d uA(poseA[0], poseA[1], poseA[2]), tA(poseA[4], poseA[5], poseA[6]);
    const Eigen::Vector3d uB(poseB[0], poseB[1], poseB[2]), tB(poseB[4], poseB[5], poseB[6]);
    const double wA = poseA[3], wB = poseB[3];
    const Eigen::Vector3d a = bearingA_ - rho * tA;
    const Eigen::Matrix3d MAinv = detail::rotationOperator(-uA, wA);  // conj(qA) = (-uA, wA)
    const Eigen::Matrix3d MB = detail::rotationOperator(uB, wB);
    const Eigen::Vector3d m = MAinv * a;
    const Eigen::Vector3d h = MB * m + rho * tB;
    Eigen::Matrix<double, 2, 3> Jh;
    detail::projectWhitened(h, camera_, observed_, sqrtInformation_, residuals, Jh);
    if (!jacobians) return true;
    const Eigen::Matrix<double, 2, 3> JhMB = Jh * MB;
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 2, kPoseSize, Eigen::RowMajor>> J(jacobians[0]);
      Eigen::Matrix<double, 3, 4> dm_dqA = detail::rotationJacobian(-uA, wA, a);
      dm_dqA.leftCols<3>() *= -1.0;  // d/duA of a function of -uA
      J.leftCols<4>() = JhMB * dm_dqA;
      J.rightCols<3>() = -rho * JhMB * MAinv;
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 2, kPoseSize, Eigen::RowMajor>> J(jacobians[1]);
      J.leftCols<4>() = Jh * detail::rotationJacobian(uB, wB, m);
      J.rightCols<3>() = rho * Jh;
    }
    if (jacobians[2]) {
      Eigen::Map<Eigen::Vector2d> J(jacobians[2]);
      J = Jh * (tB - MB * (MAinv * tA));
    }
    return true;
  }

 private:
  Eigen::Vector3d bearingA_;
  Eigen::Vector2d observed_;
  double sqrtInformation_;
  geometry::PinholeCamera camera_;
};

}  // namespace pslam::optimize
