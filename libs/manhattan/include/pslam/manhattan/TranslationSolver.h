#pragma once
// Translation with a known rotation (thesis §4.4.1, eqs. 2.33, 2.34 and 4.1): once the Manhattan frame
// fixes the rotation, the translation has 3 DoF and each correspondence gives a linear constraint.
//
// Frames: R_cur_prev and t_cur_prev map previous-frame coordinates to the current frame,
// X_cur = R_cur_prev X_prev + t_cur_prev. Bearings are normalized image coordinates (x, y, 1) or unit rays.
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Params.h"
namespace pslam::manhattan {

/// Linear least-squares direction of t from 2D-2D correspondences (eq. 2.34): every pair gives the row
/// (R f_prev x f_cur)^T t = 0 and t is the right singular vector of the smallest singular value. The sign is
/// chosen so that most points lie in front of both cameras; |t| = 1. Needs >= 2 pairs.
Eigen::Vector3d solveTranslationDirection(const std::vector<Eigen::Vector3d>& bearingsPrev,
                                          const std::vector<Eigen::Vector3d>& bearingsCur,
                                          const Eigen::Matrix3d& R_cur_prev);

/// Linear least-squares metric t from 3D points in the previous frame and their normalized image coordinates
/// (x, y) in the current frame: x (r3 X + t3) = r1 X + t1, y (r3 X + t3) = r2 X + t2 (eq. 2.33 with a known
/// depth). Needs >= 2 points.
Eigen::Vector3d solveTranslationMetric(const std::vector<Eigen::Vector3d>& pointsPrev,
                                       const std::vector<Eigen::Vector2d>& normalizedCur,
                                       const Eigen::Matrix3d& R_cur_prev);

struct TranslationRansacParams {
  int maxIterations = 500;
  double confidence = 0.999;
  double inlierThreshold = 2.0e-3;
  std::size_t minInliers = 8;
  unsigned seed = 7;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, maxIterations, atLeast(1), "RANSAC iterations");
    PSLAM_FIELD(v, confidence, inOpen(0, 1), "early stop once this probability of an all-inlier sample is reached");
    PSLAM_FIELD(v, inlierThreshold, greaterThan(0), "2D-2D: sine of the angle to the epipolar plane; 3D-2D: normalized px");
    PSLAM_FIELD(v, minInliers, atLeast(2), "fewer inliers: no estimate");
    PSLAM_FIELD(v, seed, anyValue, "RANSAC seed");
  }
  PSLAM_PARAMS("TranslationRansac")
};

struct TranslationEstimate {
  Eigen::Vector3d t_cur_prev = Eigen::Vector3d::Zero();
  std::vector<bool> inliers;
  std::size_t inlierCount = 0;
  int iterations = 0;
  bool valid = false;
};

/// RANSAC over 2-pair minimal samples of eq. 2.34, refit on the inliers. Seeded by params.seed.
TranslationEstimate ransacTranslationDirection(const std::vector<Eigen::Vector3d>& bearingsPrev,
                                               const std::vector<Eigen::Vector3d>& bearingsCur,
                                               const Eigen::Matrix3d& R_cur_prev, const TranslationRansacParams& params);

/// RANSAC over 2-point minimal samples of the metric 3D-2D system, refit on the inliers.
TranslationEstimate ransacTranslationMetric(const std::vector<Eigen::Vector3d>& pointsPrev,
                                            const std::vector<Eigen::Vector2d>& normalizedCur,
                                            const Eigen::Matrix3d& R_cur_prev, const TranslationRansacParams& params);

}  // namespace pslam::manhattan
