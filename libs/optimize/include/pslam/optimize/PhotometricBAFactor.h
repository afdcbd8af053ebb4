#pragma once
// The photometric error of one direct point observed in one target keyframe as a factor of local / global BA
// (BAFactor): the 9 whitened pattern residuals r_k = sqrt(eta_P / eta_R) e_k of PhotometricError.h over
//   [host pose (7), target pose (7)]  (PoseParameterization.h, T_cam_world), the landmark block [rho (1)],
//   then, when free, the shared blocks [host (a, b)] and/or [target (a, b)] (AffineBlock, §3.2.2: the affine
//   brightness estimated jointly with poses and points).
// Analytic Jacobians w.r.t. the blocks' ambient parameters (quaternion coefficients included; Ceres maps them to
// the PoseManifold tangent), with the gradient of the bilinear target interpolant as in the pose factor; the tests
// check them against ceres::GradientChecker and an automatic-differentiation version of the same cost
// (ImagePyramid.h's Jet overload of the interpolant), about 20x slower. A pattern pixel behind
// the target fails the evaluation (Ceres rejects that step; the outlier test then flags the factor); pixels
// leaving the image are clamped to its border (constant residual, zero gradient), so the solver keeps going
// and the chi-square test decides. Huber delta and outlier threshold as in PhotometricPoseFactor.
#include <array>
#include <memory>

#include "pslam/optimize/BAFactor.h"
#include "pslam/optimize/PhotometricError.h"

namespace pslam::optimize {

/// A keyframe's affine brightness (a, b) (AffineBrightness) as a BA parameter block, shared by the photometric
/// factors of that keyframe. Fix it for at least one keyframe (e.g. the fixed ones): shifting every a by the
/// same constant changes no residual.
struct AffineBlock {
  std::array<double, 2> ab{0.0, 0.0};  ///< (a, b)
  bool fixed = true;                   ///< fixed: data of the factors; free: a shared block updated by BA
  AffineBrightness value() const { return {ab[0], ab[1]}; }
};

class PhotometricBAFactor : public BAFactor {
 public:
  /// `point` (host keyframe point->host, inverse depth updated in place by BA), observed in keyframe `target`
  /// (!= host) whose pyramid is `targetImage`; `camera`: level-0 intrinsics; null affine blocks mean (0, 0)
  /// fixed. Throws pslam::Error on null point/image, target == host or a level the point / image lacks.
  PhotometricBAFactor(std::shared_ptr<DirectLandmark> point, map::KeyFrameId target,
                      std::shared_ptr<const ImagePyramid> targetImage, const geometry::PinholeCamera& camera,
                      std::shared_ptr<AffineBlock> hostAffine = nullptr,
                      std::shared_ptr<AffineBlock> targetAffine = nullptr, int level = 0,
                      const PhotometricParams& params = {});

  std::string kind() const override { return "direct"; }
  std::vector<map::KeyFrameId> keyframes() const override { return {point_->host, target_}; }
  std::vector<double*> landmarkBlocks() const override { return {&point_->inverseDepth}; }
  std::vector<double*> sharedBlocks() const override;
  ceres::CostFunction* newCostFunction() const override;
  bool landmarkFixed() const override { return point_->fixed; }
  double huberDelta() const override { return params_.whitenedHuberDelta(); }
  double chi2Threshold() const override { return params_.whitenedChi2Threshold(); }

  const DirectLandmark& point() const { return *point_; }
  map::KeyFrameId target() const { return target_; }

 private:
  std::shared_ptr<DirectLandmark> point_;
  map::KeyFrameId target_;
  std::shared_ptr<const ImagePyramid> image_;
  geometry::PinholeCamera camera_;
  std::shared_ptr<AffineBlock> hostAffine_, targetAffine_;
  int level_;
  PhotometricParams params_;
};

}  // namespace pslam::optimize
