#pragma once
// The photometric error of one direct point as an observation of motion-only pose optimization (PoseFactor):
// the 9 whitened pattern residuals r_k = sqrt(eta_P / eta_R) e_k of PhotometricError.h in a target frame whose
// pose is optimized; the host pose, the inverse depth and both affine brightness parameters are constants.
// Analytic Jacobian w.r.t. the left perturbation T_target_world <- Exp(xi) T_target_world, xi = (omega, v):
//   dr_k/dxi = sqrt(eta_P / eta_R) * g_k^T * dpi(q_k)/dq * [ -[q_k]x | rho_z I ]
// with g_k the gradient of the bilinear target interpolant at u_k (q_k = rho_z X_target,k is homogeneous).
// Huber delta and outlier threshold: delta_P = 0.4 sqrt(eta_P) and chi2_P = 0.05 N_P of Table 3.2 in whitened
// units (PhotometricParams). Evaluated at one pyramid level; optimizePoseCoarseToFine runs the levels coarse to
// fine (§3.4.2).
#include <memory>
#include <vector>

#include "pslam/optimize/PhotometricError.h"
#include "pslam/optimize/PoseFactor.h"
#include "pslam/optimize/PoseOptimizer.h"

namespace pslam::optimize {

class PhotometricPoseFactor : public PoseFactor {
 public:
  /// `camera`: level-0 intrinsics of the target (and host) camera. `target`: the target frame's pyramid, shared
  /// (not copied). Throws pslam::Error on null pointers, a level beyond the target pyramid or the point's levels.
  PhotometricPoseFactor(std::shared_ptr<const DirectLandmark> point, const Eigen::Isometry3d& T_host_world,
                        const AffineBrightness& hostAffine, std::shared_ptr<const ImagePyramid> target,
                        const AffineBrightness& targetAffine, const geometry::PinholeCamera& camera, int level = 0,
                        const PhotometricParams& params = {});

  /// The same observation at another pyramid level (cheap: the point and the image are shared).
  std::shared_ptr<PhotometricPoseFactor> atLevel(int level) const;
  int level() const { return level_; }
  const DirectLandmark& point() const { return *point_; }

  std::string kind() const override { return "direct"; }
  int dimension() const override { return kPatternSize; }
  /// False (an outlier for optimizePose) when a pattern pixel projects behind the target or outside its image, or
  /// the point has no host intensities at this level; the residual is then that of the border-clamped samples.
  bool evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                Eigen::MatrixXd* jacobian) const override;
  double huberDelta() const override { return params_.whitenedHuberDelta(); }
  double chi2Threshold() const override { return params_.whitenedChi2Threshold(); }
  /// evaluate() in fixed-size (9 x 6) matrices: the same terms without the dynamic-size products (pose
  /// optimization spends most of its time in the direct factors).
  bool addTo(PoseNormalEquations& eq, const Eigen::Isometry3d& T_cam_world, double huberDelta) const override;
  bool squaredResidual(const Eigen::Isometry3d& T_cam_world, double& chi2) const override;

  /// Unweighted pattern error e (and its validity) at a target pose, for diagnostics and matching accuracy.
  PatternError patternError(const Eigen::Isometry3d& T_target_world) const;

 private:
  using Residual = Eigen::Matrix<double, kPatternSize, 1>;
  using Jacobian = Eigen::Matrix<double, kPatternSize, 6>;
  bool evaluateFixed(const Eigen::Isometry3d& T_cam_world, Residual& residual, Jacobian* jacobian) const;

  std::shared_ptr<const DirectLandmark> point_;
  Eigen::Isometry3d T_host_world_, T_world_host_;
  AffineBrightness hostAffine_, targetAffine_;
  std::shared_ptr<const ImagePyramid> target_;
  geometry::PinholeCamera camera_;
  int level_ = 0;
  PhotometricParams params_;
  std::array<Eigen::Vector3d, kPatternSize> rays_;  ///< pattern rays m_k at level_
};

/// Coarse-to-fine motion-only optimization (thesis §3.4.2, DSO's coarse tracking): optimizePose once per pyramid
/// level from `coarsestLevel` down to 0, the direct factors evaluated at that level (PhotometricPoseFactor::
/// atLevel; points without intensities at a level sit it out), each level starting at the pose of the previous
/// one. Keypoint observations and `otherFactors` take part unchanged at every level (pass none for direct
/// alignment alone). The coarse levels (> 0) run one robust round of `params` (they only bring the estimate into
/// the basin of the finer levels); level 0 runs all rounds with the outlier classification.
/// The target pyramids need more than `coarsestLevel` levels (else pslam::Error). Returns the
/// level-0 result; its factorOutlier lists `direct` first, then `otherFactors`.
PoseOptimizationResult optimizePoseCoarseToFine(const Eigen::Isometry3d& T_cam_world_initial,
                                                const geometry::PinholeCamera& camera,
                                                const std::vector<PoseObservation>& observations,
                                                const std::vector<std::shared_ptr<const PhotometricPoseFactor>>& direct,
                                                int coarsestLevel, const PoseOptimizationParams& params = {},
                                                const std::vector<std::shared_ptr<const PoseFactor>>& otherFactors = {});

}  // namespace pslam::optimize
