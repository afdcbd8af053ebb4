#pragma once
// Similarity between two keyframes from matched map points, for loop closing (ORB-SLAM2's Sim3Solver).
//
// A monocular map drifts in scale, so the transform between a keyframe and its loop candidate is a Sim(3):
// p1 = s R p2 + t, with p1 / p2 the same physical point in the coordinates of camera 1 / camera 2 (each from its
// own keyframe's map points, hence in each map's own scale). RANSAC over minimal sets of 3 correspondences, each
// solved in closed form (Horn / Umeyama with scale, Eigen::umeyama). A hypothesis is scored in the images, not in
// 3-D: map-point positions are uncertain along the viewing ray, while the keypoints are measured to about a
// pixel times their pyramid level's scale, so a correspondence is an inlier when its reprojection passes a chi^2
// test in BOTH images (ORB-SLAM's CheckInliers). Unlike ORB-SLAM a point behind either camera is an outlier: a
// point and its mirror image through the camera centre project to the same pixel.
//
// Differences to ORB-SLAM: all iterations run in one call (ORB-SLAM interleaves candidates 5 iterations at a
// time), the number of iterations adapts to the best inlier ratio found so far, and the best hypothesis is
// refined by Umeyama on all its inliers (ORB-SLAM refines later, by Sim(3) reprojection optimization).
//
// Pixels are undistorted (ideal pinhole cameras K1, K2). Determinism: every random draw comes from the caller's
// std::mt19937; the same generator state and input give the same result.
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Params.h"
#include "pslam/geometry/Sim3.h"

namespace pslam::geometry {

struct Sim3RansacParams {
  int maxIterations = 300;    ///< ORB-SLAM: up to 300 (5 per call)
  double probability = 0.99;  ///< stop early once an all-inlier sample was drawn with this confidence
  int minInliers = 20;        ///< ORB-SLAM: 20
  double chi2 = 9.210;        ///< reprojection test in each image: chi^2(2 dof, 99 %), times the keypoint variance

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, maxIterations, atLeast(1), "RANSAC iterations at most (minimal sets drawn, degenerate ones included)");
    PSLAM_FIELD(v, probability, inOpen(0, 1), "confidence of having drawn one all-inlier sample (adaptive stop)");
    PSLAM_FIELD(v, minInliers, atLeast(3), "fewer inliers = failure (a minimal set has 3 correspondences)");
    PSLAM_FIELD(v, chi2, greaterThan(0), "inlier if squared reprojection error < chi2 * sigma^2 in both images (2 dof, 99 %)");
  }
  PSLAM_PARAMS("Sim3Ransac")
};

struct Sim3Correspondence {
  Eigen::Vector3d p1 = Eigen::Vector3d::Zero();  ///< the point in camera-1 coordinates (keyframe 1's map point)
  Eigen::Vector3d p2 = Eigen::Vector3d::Zero();  ///< the same physical point in camera-2 coordinates (keyframe 2's)
  Eigen::Vector2d px1 = Eigen::Vector2d::Zero();  ///< its keypoint pixel in image 1
  Eigen::Vector2d px2 = Eigen::Vector2d::Zero();  ///< its keypoint pixel in image 2
  double sigma2_1 = 1.0;  ///< keypoint position variance in image 1 (pyramid level's sigma^2, pixels^2)
  double sigma2_2 = 1.0;  ///< ... in image 2
};

enum class Sim3Failure { None, TooFewCorrespondences, InvalidInput, AllSamplesDegenerate, TooFewInliers };
const char* toString(Sim3Failure failure);

struct Sim3RansacResult {
  bool success = false;
  Sim3Failure failure = Sim3Failure::None;
  /// Maps camera-2 coordinates to camera-1 coordinates: p1 ~ S12.map(p2). On TooFewInliers the best hypothesis
  /// found (for diagnostics); identity when no hypothesis was made.
  Sim3 S12;
  std::vector<bool> inliers;  ///< per correspondence, with S12
  int numInliers = 0;
  int iterations = 0;   ///< minimal sets drawn
  std::string message;  ///< why it failed; a summary on success
};

/// True when `m` passes the reprojection test of S12 in both images: |proj(K1, S12.map(p2)) - px1|^2 <
/// chi2 * sigma2_1 and |proj(K2, S12.inverse().map(p1)) - px2|^2 < chi2 * sigma2_2, both points in front of their
/// camera (depth > 0). S21 must be S12.inverse() (passed in so that scoring many matches inverts once).
bool isSim3Inlier(const Sim3Correspondence& m, const Sim3& S12, const Sim3& S21, const Eigen::Matrix3d& K1,
                  const Eigen::Matrix3d& K2, double chi2);

/// RANSAC over minimal sets of 3 correspondences (closed form by Umeyama with scale). The hypothesis with the
/// most inliers is refined by Umeyama on all its inliers and its inliers recomputed; the refined one is kept only
/// if it has at least as many inliers (Umeyama minimizes 3-D distances, the score counts image residuals).
/// Success needs numInliers >= minInliers. Degenerate samples (coincident or collinear points in either camera)
/// are skipped but counted as iterations. Returns a failed result (never throws) for fewer than 3 or fewer than
/// minInliers correspondences, non-finite input or non-positive variances, only degenerate samples, or too few
/// inliers. Throws pslam::Error for invalid params or a K that is not a pinhole matrix.
Sim3RansacResult estimateSim3Ransac(const std::vector<Sim3Correspondence>& matches, const Eigen::Matrix3d& K1,
                                    const Eigen::Matrix3d& K2, const Sim3RansacParams& params, std::mt19937& rng);

}  // namespace pslam::geometry
