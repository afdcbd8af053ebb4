#pragma once
// The observation-kind extension point of bundle adjustment. ORB keypoints on inverse-depth points are the
// built-in kind (BAObservation); any other landmark kind -- a DSO-style direct point with its photometric
// error (thesis Table 3.2), a 3D line with the point-to-line error of its segment endpoints (eq. 2.59) --
// joins the same local / global BA by implementing BAFactor: a Ceres cost function over the pose blocks of
// the keyframes it involves (PoseParameterization.h) followed by its landmark's own parameter blocks, which
// the factor owns and Ceres updates in place. Landmark blocks are eliminated in the Schur complement with
// the inverse depths; each factor has its own Huber delta (first pass) and chi-square outlier test.
// Parameters shared by the landmarks of many factors -- per-keyframe quantities such as the affine brightness
// (a, b) of a direct point's host and target frames (§3.2.2) -- are sharedBlocks(): they follow the landmark
// blocks and stay with the poses in the Schur complement (an eliminated block may not share a residual with
// another eliminated block, so they cannot be landmark blocks).
#include <string>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include "pslam/map/Types.h"

namespace pslam::optimize {

class BAFactor {
 public:
  virtual ~BAFactor() = default;
  /// Name of the observation kind ("direct", "line", ...), for reports.
  virtual std::string kind() const = 0;
  /// Keyframes whose pose blocks (kPoseSize doubles, T_cam_world) are the cost function's first parameters.
  virtual std::vector<map::KeyFrameId> keyframes() const = 0;
  /// The landmark's parameter blocks that follow the poses, owned by the factor (several factors of one
  /// landmark return the same pointers). Updated in place by the optimizer.
  virtual std::vector<double*> landmarkBlocks() const = 0;
  /// Free blocks shared with other landmarks' factors (e.g. a keyframe's affine brightness, 2 doubles), owned
  /// outside the factor and updated in place; not eliminated in the Schur complement. Default: none.
  virtual std::vector<double*> sharedBlocks() const { return {}; }
  /// A new cost function (Ceres takes ownership) whose parameter blocks are keyframes() then landmarkBlocks()
  /// then sharedBlocks(), with a whitened residual.
  virtual ceres::CostFunction* newCostFunction() const = 0;
  /// Manifold of landmark block `i` (Ceres takes ownership), or null for a Euclidean block.
  virtual ceres::Manifold* newLandmarkManifold(std::size_t i) const { return nullptr; }
  /// Hold the landmark blocks constant?
  virtual bool landmarkFixed() const { return false; }
  virtual double huberDelta() const = 0;
  virtual double chi2Threshold() const = 0;
};

}  // namespace pslam::optimize
