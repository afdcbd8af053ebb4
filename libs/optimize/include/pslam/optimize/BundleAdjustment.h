#pragma once
// Bundle adjustment of keyframe poses and inverse-depth map points (eq. 3.1, residual (b)) with Ceres:
// SPARSE_SCHUR on SuiteSparse, inverse depths eliminated first, Huber loss on whitened residuals.
// The problem is described on plain types (ids, Eigen, intrinsics); MapAdapter.h builds it from a
// pslam::map::Map and writes the result back.
#include <atomic>
#include <cstddef>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "pslam/map/Types.h"
#include "pslam/optimize/BAFactor.h"
#include "pslam/optimize/Params.h"

namespace pslam::optimize {

struct BAKeyFrame {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  geometry::PinholeCamera camera;
  bool fixed = false;  ///< held constant (gauge / keyframes outside the local window)
};

struct BAPoint {
  map::KeyFrameId anchor = map::kNoKeyFrame;  ///< must be in BAProblem::keyframes
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  ///< unit, anchor camera frame
  double inverseDepth = 1.0;
  bool fixed = false;
};

struct BAObservation {
  map::KeyFrameId keyframe = map::kNoKeyFrame;
  map::MapPointId point = map::kNoMapPoint;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double invSigma2 = 1.0;
};

struct BAProblem {
  std::map<map::KeyFrameId, BAKeyFrame> keyframes;
  std::map<map::MapPointId, BAPoint> points;
  std::vector<BAObservation> observations;
  /// Observations of other landmark kinds (BAFactor.h), optimized jointly; their landmark blocks are updated
  /// in place.
  std::vector<std::shared_ptr<BAFactor>> factors;
};

struct BAResult {
  std::map<map::KeyFrameId, Eigen::Isometry3d> poses;  ///< every non-fixed keyframe that was optimized
  std::map<map::MapPointId, double> inverseDepths;     ///< every non-fixed point that was optimized
  std::vector<std::size_t> outliers;  ///< observation indices with chi2 > threshold or negative depth at the end
  std::vector<std::size_t> factorOutliers;  ///< indices into BAProblem::factors with chi2 > their threshold at the end
  double initialCost = 0.0, finalCost = 0.0;  ///< Ceres cost (1/2 sum of robustified squares), first/last pass
  /// Unweighted reprojection RMS (pixels) before / after, over the non-anchor observations that are
  /// inliers at the end.
  double initialRmsPixels = 0.0, finalRmsPixels = 0.0;
  int iterations = 0;       ///< LM iterations over both passes
  bool stopped = false;     ///< a stop request ended it early (no second pass)
  int residualBlocks = 0;   ///< in the first pass
  double solveSeconds = 0.0;         ///< wall time of the whole call
  double jacobianSeconds = 0.0;      ///< Ceres: residual + Jacobian evaluation, both passes
  double linearSolverSeconds = 0.0;  ///< Ceres: Schur complement + sparse Cholesky, both passes
};

/// Two-pass local BA (ORB-SLAM): firstPassIterations with the Huber loss, then the observations with
/// chi2 > threshold or negative depth are dropped and secondPassIterations run without the loss. Which
/// keyframes/points are free is given by their `fixed` flags. Throws pslam::Error on inconsistent input
/// (unknown ids, non-finite values, no fixed keyframe).
/// `stop` (optional, may be set from another thread): ORB-SLAM's abort flag. Once set, the running pass ends after
/// its current iteration and the second pass is skipped; the result (outliers included) is that of the point
/// reached, and BAResult::stopped says so.
BAResult localBundleAdjustment(const BAProblem& problem, const BundleAdjustmentParams& params = {},
                               const std::atomic<bool>* stop = nullptr);

/// Global BA of a map: the keyframe with the lowest id is fixed in addition to any flagged ones, globalIterations
/// with the Huber loss; outliers are reported, not removed. `stop`: as for localBundleAdjustment (a loop found
/// while the previous loop's global BA runs stops it).
BAResult globalBundleAdjustment(const BAProblem& problem, const BundleAdjustmentParams& params = {},
                                const std::atomic<bool>* stop = nullptr);


}  // namespace pslam::optimize
