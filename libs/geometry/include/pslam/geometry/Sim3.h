#pragma once
// A similarity transform of R^3 (Sim(3)): x' = s R x + t. Monocular maps drift in scale, so loop closing
// estimates and propagates corrections as similarities (ORB-SLAM's g2o::Sim3). Naming follows the poses: S_a_b
// maps coordinates in frame b to frame a.
#include <Eigen/Geometry>

namespace pslam::geometry {

struct Sim3 {
  double s = 1.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Sim3() = default;
  Sim3(double scale, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
      : s(scale), R(rotation), t(translation) {}
  /// The rigid transform T as a similarity of scale 1.
  static Sim3 fromIsometry(const Eigen::Isometry3d& T) { return {1.0, T.linear(), T.translation()}; }

  Eigen::Vector3d map(const Eigen::Vector3d& x) const { return s * (R * x) + t; }
  Sim3 operator*(const Sim3& o) const { return {s * o.s, R * o.R, s * (R * o.t) + t}; }
  Sim3 inverse() const {
    const Eigen::Matrix3d Rt = R.transpose();
    return {1.0 / s, Rt, -(Rt * t) / s};
  }
  /// The rigid part with the translation divided by the scale: for S_cw = s [R|t] of a camera, the camera pose
  /// T_cw = [R | t / s] in the world of the similarity (ORB-SLAM's conversion after the essential graph).
  Eigen::Isometry3d toIsometryUnscaled() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = t / s;
    return T;
  }
};

}  // namespace pslam::geometry
