#pragma once
// Camera pose from 2D-3D correspondences for relocalization (thesis §2.3.2.1, "Rotation + Translation
// (3D-2D)", eq. 2.30): RANSAC over EPnP minimal sets (cv::solvePnPRansac), then Levenberg-Marquardt
// refinement on the inliers (cv::solvePnPRefineLM) and a final inlier test with the refined pose.
//
// Pixels are undistorted (ideal pinhole camera). The pose is T_cam_world: X_cam = R X_world + t.
// Determinism: OpenCV's classic RANSAC draws its samples from a cv::RNG with a fixed internal seed, so
// equal inputs give equal outputs; no global random state is touched.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/poses/CPose3D.h>

#include "pslam/core/Params.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam::geometry {

struct PnpParams {
  int ransacIterations = 300;
  double sigma = 1.0;
  double chi2Threshold = 5.991;
  double confidence = 0.99;
  int minInliers = 15;
  bool refine = true;
  /// Minimal solver inside RANSAC: "epnp" (5 points a sample) or "ap3p" (4: three and one to choose among the
  /// solutions; cheaper, and fewer samples for the same confidence).
  std::string minimalSolver = "epnp";

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, ransacIterations, atLeast(1), "RANSAC iterations");
    PSLAM_FIELD(v, sigma, greaterThan(0), "keypoint position std (pixels)");
    PSLAM_FIELD(v, chi2Threshold, greaterThan(0), "inlier if squared reprojection error <= chi2 * sigma^2 (2 dof, 95 %)");
    PSLAM_FIELD(v, confidence, inOpen(0, 1), "RANSAC confidence");
    PSLAM_FIELD(v, minInliers, atLeast(4), "fewer inliers after refinement = failure (a pose has 6 degrees of freedom)");
    PSLAM_FIELD(v, refine, anyValue, "Levenberg-Marquardt refinement on the RANSAC inliers");
    PSLAM_FIELD(v, minimalSolver, oneOf({"epnp", "ap3p"}), "minimal solver of the RANSAC samples");
  }
  PSLAM_PARAMS("Pnp")
};

enum class PnpFailure { None, TooFewCorrespondences, InvalidInput, RansacFailed, TooFewInliers };
const char* toString(PnpFailure failure);

struct PnpResult {
  bool success = false;
  PnpFailure failure = PnpFailure::None;
  std::string message;
  Eigen::Matrix3d R_cam_world = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_cam_world = Eigen::Vector3d::Zero();
  std::vector<bool> inliers;  ///< per correspondence, with the final pose
  int numInliers = 0;
  double rmsReprojectionError = 0.0;  ///< over the inliers, pixels

  mrpt::poses::CPose3D poseCamWorld() const;
};

/// RANSAC iterations for n correspondences and samples of sampleSize points (ORB-SLAM's PnPsolver rule):
/// enough to draw an all-inlier sample with params.confidence when minInliers of them are inliers, at most
/// params.ransacIterations; 1 when n <= minInliers.
int ransacIterationBudget(const PnpParams& params, std::size_t correspondences, int sampleSize);

/// points_world[i] is observed at pixels[i]. Returns a failed result (never throws) for too few
/// correspondences (< 4 or < minInliers), non-finite input, or too few inliers.
PnpResult solvePnpRansac(const PinholeCamera& camera, const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels, const PnpParams& params = {});

}  // namespace pslam::geometry
