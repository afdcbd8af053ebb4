#pragma once
// An absolute rotation measurement of one keyframe as a factor of local / global BA (BAFactor): the
// keyframe's Manhattan frame (§4.4, Frame::R_cam_mf) against the global one gives R_cam_world without drift,
// up to the normals' error. The residual is the rotation between the pose block's R_cam_world and the measured
// one, in the tangent space of the PoseManifold's left-multiplied increments, whitened by sigma [rad]:
//   r = Log(R(q) R_meas^T) / sigma      (3 residuals; the translation takes no part)
// Automatic differentiation (the tests check it with ceres::GradientChecker and against a rotation whose error
// is known). Huber delta and outlier threshold at chi2(3 DoF, 95 %) = 7.815: a keyframe whose Manhattan frame
// disagrees with its points by several sigma leaves the second BA pass, as an outlier keypoint does.
#include <cmath>

#include <Eigen/Geometry>

#include "pslam/optimize/BAFactor.h"
#include "pslam/optimize/PoseFactor.h"

namespace pslam::optimize {

inline constexpr double kRotationPriorChi2 = 7.815;  ///< chi2 with 3 DoF at 95 %

class RotationPriorFactor : public BAFactor {
 public:
  /// `R_cam_world`: the measured rotation of keyframe `keyframe`; `sigmaRad` > 0 its standard deviation per
  /// axis. Throws pslam::Error on a non-rotation or a bad sigma.
  RotationPriorFactor(map::KeyFrameId keyframe, const Eigen::Matrix3d& R_cam_world, double sigmaRad);

  std::string kind() const override { return "rotation_prior"; }
  std::vector<map::KeyFrameId> keyframes() const override { return {keyframe_}; }
  std::vector<double*> landmarkBlocks() const override { return {}; }
  ceres::CostFunction* newCostFunction() const override;
  double huberDelta() const override { return std::sqrt(kRotationPriorChi2); }
  double chi2Threshold() const override { return kRotationPriorChi2; }

  /// The whitened residual for a pose block (PoseParameterization.h); for tests and reports.
  Eigen::Vector3d residual(const double* pose) const;

 private:
  map::KeyFrameId keyframe_;
  Eigen::Quaterniond q_meas_;
  double invSigma_;
};

/// The same measurement as a factor of one frame's motion-only pose optimization (PoseFactor): a soft Manhattan
/// rotation in tracking (`[Manhattan] trackingRotationSigmaDeg` > 0) instead of the thesis' fixed one (eq. 4.2),
/// for normals whose rotation is a few degrees off (a network's). Residual r = Log(R R_meas^T) / sigma with the
/// analytic Jacobian w.r.t. the left perturbation R <- exp(omega) R: dr/domega = J_l^-1(Log(R R_meas^T)) / sigma,
/// zero for the translation. Same Huber delta and chi-square threshold as the BA form.
class RotationPosePriorFactor : public PoseFactor {
 public:
  /// Throws pslam::Error on a non-rotation or a bad sigma.
  RotationPosePriorFactor(const Eigen::Matrix3d& R_cam_world, double sigmaRad);

  std::string kind() const override { return "rotation_prior"; }
  int dimension() const override { return 3; }
  bool evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                Eigen::MatrixXd* jacobian) const override;
  double huberDelta() const override { return std::sqrt(kRotationPriorChi2); }
  double chi2Threshold() const override { return kRotationPriorChi2; }

 private:
  Eigen::Matrix3d R_meas_;
  double invSigma_;
};

}  // namespace pslam::optimize
