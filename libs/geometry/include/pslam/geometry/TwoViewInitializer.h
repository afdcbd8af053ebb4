#pragma once
// Relative pose initialization from two views (thesis §2.3.2.1, Algorithm 1; ORB-SLAM's Initializer).
//
// A homography (normalized DLT, eq. 2.48) and a fundamental matrix (normalized 8-point, eq. 2.36-2.43) are
// estimated by RANSAC over the SAME pre-drawn 8-point sample sets, in parallel or sequentially (identical
// results). The model is chosen by R_H = S_H / (S_H + S_F) > homographyRatioThreshold and decomposed: the
// 8 Faugeras solutions of H (eq. 2.49-2.54) or the 4 solutions of E = K^T F K (eq. 2.44-2.45); each is
// triangulated (eq. 2.23) and checked for cheirality, parallax and re-projection error, and the best is
// accepted only if it is clearly better than the others. Two additions to ORB-SLAM, both switchable:
// a least-squares refit of each model on its inliers, and a Sampson-error refinement of the best F-based
// pose (doc/geometry.md has the measured effect).
//
// Frames: the reference camera is the world frame. The result (R_cur_ref, t_cur_ref) maps reference
// camera points into the current camera, X_cur = R X_ref + t, with ||t|| = 1 (scale is unobservable).
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/poses/CPose3D.h>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam::geometry {

struct TwoViewParams {
  int ransacIterations = 200;
  double sigma = 1.0;
  /// Homography chosen when S_H / (S_H + S_F) > this. ORB-SLAM's code uses 0.40 (its paper: 0.45).
  /// Algorithm 1 of the thesis takes the better score, i.e. 0.5; the thesis builds on ORB-SLAM's
  /// initializer (§3.4.1), so its value is the default.
  double homographyRatioThreshold = 0.40;
  double minParallaxDeg = 1.0;
  int minTriangulated = 50;
  double minTriangulatedFraction = 0.9;
  double similarSolutionFractionF = 0.7;
  double secondBestFractionH = 0.75;
  /// A homography whose best decomposition ties with another (the plane's twin: for a camera moving parallel
  /// to a plane, (R, t, n) and its twin explain every point on the plane) is resolved by the matches off the
  /// plane: they satisfy only the true motion's epipolar geometry. The winner needs at least this many of them
  /// triangulated and more than twice as many as each tied decomposition. 0 = ORB-SLAM (the frame is skipped).
  int minOffPlaneSupportH = 10;
  bool parallel = true;
  /// Least-squares refits of the best model on its inliers (each kept only if the score rises).
  /// 0 = ORB-SLAM's behaviour (pose from the best 8-point hypothesis).
  int refitIterations = 2;
  /// Refine an accepted F-based (R, t) by minimizing the robust Sampson error of its good matches
  /// (Ceres). false = ORB-SLAM's behaviour (it relies on the global BA after initialization).
  bool refinePose = true;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, ransacIterations, atLeast(1), "RANSAC hypotheses (ORB-SLAM: 200)");
    PSLAM_FIELD(v, sigma, greaterThan(0), "keypoint position std (pixels) for all chi^2 tests");
    PSLAM_FIELD(v, homographyRatioThreshold, inClosed(0, 1), "H chosen when S_H / (S_H + S_F) > this (ORB-SLAM 0.40)");
    PSLAM_FIELD(v, minParallaxDeg, inRightOpen(0, 90), "parallax of the accepted reconstruction (ORB-SLAM: 1 deg)");
    PSLAM_FIELD(v, minTriangulated, atLeast(1), "minimum number of good triangulated points");
    PSLAM_FIELD(v, minTriangulatedFraction, inClosed(0, 1), "good points >= this * model inliers (ORB-SLAM: 0.9)");
    PSLAM_FIELD(v, similarSolutionFractionF, inLeftOpen(0, 1),
                "F: another solution with more than this * best good points is ambiguous (ORB-SLAM 0.7)");
    PSLAM_FIELD(v, secondBestFractionH, inLeftOpen(0, 1),
                "H: the second best solution must have fewer than this * best good points (ORB-SLAM 0.75)");
    PSLAM_FIELD(v, minOffPlaneSupportH, atLeast(0),
                "H: a tied (plane twin) decomposition is resolved by >= this many off-plane matches; 0 = ORB-SLAM");
    PSLAM_FIELD(v, parallel, anyValue, "run H and F RANSAC as two std::async tasks");
    PSLAM_FIELD(v, refitIterations, atLeast(0), "least-squares refits of the best model; 0 = ORB-SLAM");
    PSLAM_FIELD(v, refinePose, anyValue, "refine an F-based (R, t) on the robust Sampson error; false = ORB-SLAM");
  }
  PSLAM_PARAMS("TwoView")
};

enum class TwoViewModel { None, Homography, Fundamental };

enum class TwoViewFailure {
  None,               ///< success
  TooFewMatches,      ///< fewer than 8 matches, or fewer than minTriangulated
  InvalidInput,       ///< non-finite coordinates or match index out of range
  NoModel,            ///< every RANSAC hypothesis was degenerate
  LowParallax,        ///< best reconstruction has parallax below minParallaxDeg (e.g. pure rotation)
  TooFewTriangulated, ///< best reconstruction has too few good points
  Ambiguous,          ///< several decompositions explain the data about equally well
};

const char* toString(TwoViewModel model);
const char* toString(TwoViewFailure failure);

struct TwoViewResult {
  bool success = false;
  TwoViewFailure failure = TwoViewFailure::None;
  std::string message;  ///< human-readable detail (counts, scores) for success and failure

  Eigen::Matrix3d R_cur_ref = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_cur_ref = Eigen::Vector3d::Zero();  ///< unit norm on success

  /// Per input match (same order as the matches passed in):
  std::vector<Eigen::Vector3d> points_ref;  ///< triangulated point in the reference frame (valid if triangulated)
  std::vector<bool> triangulated;           ///< good point with enough parallax (ORB-SLAM vbTriangulated)
  std::vector<bool> inliers;                ///< inlier of the RANSAC model that was selected

  // Diagnostics
  TwoViewModel model = TwoViewModel::None;
  double scoreH = 0.0, scoreF = 0.0;
  double ratioH = 0.0;                      ///< S_H / (S_H + S_F)
  int inliersH = 0, inliersF = 0;
  Eigen::Matrix3d H_cur_ref = Eigen::Matrix3d::Zero();  ///< x_cur ~ H x_ref
  Eigen::Matrix3d F_cur_ref = Eigen::Matrix3d::Zero();  ///< x_cur^T F x_ref = 0
  int bestGood = 0, secondBestGood = 0;     ///< good points of the best / second best decomposition
  double parallaxDeg = 0.0;                 ///< parallax of the accepted (or best) decomposition
  int numTriangulated = 0;
  bool refined = false;                     ///< the Sampson refinement was applied
  /// An H decomposition tie (the plane's twin) was resolved by the matches off the plane; the counts of off-plane
  /// matches the accepted and the best other tied decomposition triangulated.
  bool twinResolved = false;
  int offPlaneGood = 0, offPlaneGoodTwin = 0;

};

/// One RANSAC sample set: 8 distinct match indices per iteration.
using SampleSets = std::vector<std::array<int, 8>>;

class TwoViewInitializer {
 public:
  TwoViewInitializer(PinholeCamera camera, TwoViewParams params = {});

  /// points_ref / points_cur: undistorted keypoint positions of the two frames; matches: (ref index,
  /// cur index) pairs. The sample sets are drawn from `rng`, so equal rng states give equal results.
  TwoViewResult initialize(const std::vector<cv::Point2f>& points_ref, const std::vector<cv::Point2f>& points_cur,
                           const std::vector<std::pair<int, int>>& matches, std::mt19937& rng) const;
  /// Convenience: point i of the reference matches point i of the current frame.
  TwoViewResult initialize(const std::vector<cv::Point2f>& points_ref, const std::vector<cv::Point2f>& points_cur,
                           std::mt19937& rng) const;

  const PinholeCamera& camera() const { return camera_; }
  const TwoViewParams& params() const { return params_; }

  // ---- Building blocks, public for tests and for other users (e.g. map initialization from a known F).
  /// `iterations` sets of 8 distinct indices in [0, numMatches), drawn by partial Fisher-Yates.
  static SampleSets drawSampleSets(int numMatches, int iterations, std::mt19937& rng);
  /// Normalized DLT homography x2 ~ H21 x1 from >= 4 correspondences (uses all given points).
  static Eigen::Matrix3d computeHomography(const std::vector<Eigen::Vector2d>& x1, const std::vector<Eigen::Vector2d>& x2);
  /// Normalized 8-point fundamental matrix x2^T F21 x1 = 0 (rank 2 enforced) from >= 8 correspondences.
  static Eigen::Matrix3d computeFundamental(const std::vector<Eigen::Vector2d>& x1, const std::vector<Eigen::Vector2d>& x2);
  /// The 4 (R, t) candidates of an essential matrix (eq. 2.44-2.45), ||t|| = 1.
  static std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> decomposeEssential(const Eigen::Matrix3d& E21);
  /// The 8 Faugeras candidates of a calibrated homography A = K^-1 H21 K (eq. 2.49-2.54), ||t|| = 1.
  /// Returns an empty vector when singular values coincide (pure rotation or motion along the normal).
  /// `normals` (optional) receives the plane normal of each candidate (sign arbitrary).
  static std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> decomposeHomography(
      const Eigen::Matrix3d& A, std::vector<Eigen::Vector3d>* normals = nullptr);

 private:
  PinholeCamera camera_;
  TwoViewParams params_;
};

}  // namespace pslam::geometry
