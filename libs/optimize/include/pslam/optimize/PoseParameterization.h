#pragma once
// SE(3) pose parameterization for Ceres (thesis §2.3.4.1).
//
// A pose T_cam_world is stored over-parameterized, without singularities, as 7 doubles
//   [qx, qy, qz, qw, tx, ty, tz]      p_cam = q * p_world + t      (Eigen quaternion coefficient order)
// and optimized through minimal 6-DoF increments on the product manifold SO(3) x R^3:
//   q <- [cos|d|, sin|d| d/|d|] * q   (ceres::EigenQuaternionManifold: a left-multiplied rotation by the
//                                      angle 2|d| about d, i.e. exp() of eq. 2.95 with omega = 2 d)
//   t <- t + dt            (ceres::EuclideanManifold<3>)
// This is the "increments around the identity applied to an over-parameterized estimate" scheme of
// §2.3.4.1; it differs from an se(3) exponential only in how rotation and translation increments couple,
// which changes the path of the solver but not its minimum.
#include <array>

#include <Eigen/Geometry>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>

namespace pslam::optimize {

inline constexpr int kPoseSize = 7;       ///< ambient size of a pose parameter block
inline constexpr int kPoseTangentSize = 6;

using PoseParameters = std::array<double, kPoseSize>;
using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

inline PoseParameters toPoseParameters(const Eigen::Isometry3d& T_cam_world) {
  const Eigen::Quaterniond q(T_cam_world.linear());
  const Eigen::Vector3d& t = T_cam_world.translation();
  const Eigen::Quaterniond qn = q.normalized();
  return {qn.x(), qn.y(), qn.z(), qn.w(), t.x(), t.y(), t.z()};
}

inline Eigen::Isometry3d fromPoseParameters(const double* pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(pose[3], pose[0], pose[1], pose[2]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose[4], pose[5], pose[6]);
  return T;
}

/// p_cam = T_cam_world * p_world for a pose block (works for doubles and ceres::Jet).
template <typename T>
Eigen::Matrix<T, 3, 1> transformPoint(const T* pose, const Eigen::Matrix<T, 3, 1>& p) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose + 4);
  return q * p + t;
}

}  // namespace pslam::optimize
