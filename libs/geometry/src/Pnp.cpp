#include "pslam/geometry/Pnp.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <mrpt/math/CMatrixFixed.h>
#include <opencv2/core/eigen.hpp>

#include "pslam/core/Error.h"
#include "pslam/geometry/Triangulation.h"

namespace pslam::geometry {

PSLAM_DEFINE_PARAMS(PnpParams)

const char* toString(PnpFailure failure) {
  switch (failure) {
    case PnpFailure::None: return "none";
    case PnpFailure::TooFewCorrespondences: return "too few correspondences";
    case PnpFailure::InvalidInput: return "invalid input";
    case PnpFailure::RansacFailed: return "RANSAC found no pose";
    case PnpFailure::TooFewInliers: return "too few inliers";
  }
  return "?";
}

mrpt::poses::CPose3D PnpResult::poseCamWorld() const {
  mrpt::math::CMatrixDouble44 T = mrpt::math::CMatrixDouble44::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T(r, c) = R_cam_world(r, c);
    T(r, 3) = t_cam_world(r);
  }
  return mrpt::poses::CPose3D(T);
}

int ransacIterationBudget(const PnpParams& params, std::size_t correspondences, int sampleSize) {
  // ORB-SLAM's PnPsolver::SetRansacParameters: a pose that can pass has at least minInliers of the n
  // correspondences as inliers, so an all-inlier sample is drawn with probability >= (minInliers / n)^s; enough
  // samples to see one with the RANSAC confidence, never more than ransacIterations. Small candidate sets that
  // fail (relocalization against keyframes that only look alike) no longer cost the full budget each.
  const double epsilon = static_cast<double>(params.minInliers) / static_cast<double>(correspondences);
  if (epsilon >= 1.0) return 1;
  const double iterations =
      std::ceil(std::log(1.0 - params.confidence) / std::log(1.0 - std::pow(epsilon, sampleSize)));
  return static_cast<int>(std::clamp(iterations, 1.0, static_cast<double>(params.ransacIterations)));
}

PnpResult solvePnpRansac(const PinholeCamera& camera, const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels, const PnpParams& params) {
  params.check();
  camera.check();
  PnpResult result;
  const std::size_t n = points_world.size();
  result.inliers.assign(n, false);
  auto fail = [&result](PnpFailure why, const std::string& message) {
    result.success = false;
    result.failure = why;
    result.message = message;
    return result;
  };
  if (pixels.size() != n) {
    return fail(PnpFailure::InvalidInput, std::to_string(n) + " world points but " + std::to_string(pixels.size()) +
                                              " pixels");
  }
  const std::size_t needed = static_cast<std::size_t>(std::max(4, params.minInliers));
  if (n < needed) {
    return fail(PnpFailure::TooFewCorrespondences,
                std::to_string(n) + " correspondences, need at least " + std::to_string(needed));
  }
  std::vector<cv::Point3d> object(n);
  std::vector<cv::Point2d> image(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!points_world[i].allFinite() || !pixels[i].allFinite()) {
      return fail(PnpFailure::InvalidInput, "correspondence " + std::to_string(i) + " has non-finite coordinates");
    }
    object[i] = {points_world[i].x(), points_world[i].y(), points_world[i].z()};
    image[i] = {pixels[i].x(), pixels[i].y()};
  }

  const cv::Mat K = camera.cvK();
  const double maxError = std::sqrt(params.chi2Threshold) * params.sigma;  // OpenCV takes a distance
  cv::Mat rvec, tvec;
  std::vector<int> ransacInliers;
  bool found = false;
  try {
    const bool ap3p = params.minimalSolver == "ap3p";
    found = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false,
                               ransacIterationBudget(params, n, ap3p ? 4 : 5), static_cast<float>(maxError),
                               params.confidence, ransacInliers, ap3p ? cv::SOLVEPNP_AP3P : cv::SOLVEPNP_EPNP);
  } catch (const cv::Exception& e) {
    return fail(PnpFailure::RansacFailed, std::string("cv::solvePnPRansac: ") + e.what());
  }
  if (!found || static_cast<int>(ransacInliers.size()) < 4) {
    return fail(PnpFailure::RansacFailed,
                "no pose with at least 4 inliers among " + std::to_string(n) + " correspondences");
  }
  if (static_cast<int>(ransacInliers.size()) < params.minInliers) {
    // The refinement only moves the pose within this consensus; no use refining a pose that cannot pass.
    return fail(PnpFailure::TooFewInliers, std::to_string(ransacInliers.size()) + " of " + std::to_string(n) +
                                               " RANSAC inliers, need " + std::to_string(params.minInliers));
  }
  if (params.refine) {
    std::vector<cv::Point3d> objectIn;
    std::vector<cv::Point2d> imageIn;
    for (int idx : ransacInliers) {
      objectIn.push_back(object[idx]);
      imageIn.push_back(image[idx]);
    }
    cv::solvePnPRefineLM(objectIn, imageIn, K, cv::noArray(), rvec, tvec);
  }
  cv::Mat Rcv;
  cv::Rodrigues(rvec, Rcv);
  cv::cv2eigen(Rcv, result.R_cam_world);
  cv::cv2eigen(tvec, result.t_cam_world);
  if (!result.R_cam_world.allFinite() || !result.t_cam_world.allFinite()) {
    return fail(PnpFailure::RansacFailed, "refined pose is not finite");
  }

  // Final inlier set with the refined pose (the RANSAC set belongs to the unrefined one).
  const Eigen::Matrix3d Ke = camera.K();
  const double sigma2 = params.sigma * params.sigma;
  double sumSq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e2 = reprojectionErrorSquared(Ke, result.R_cam_world, result.t_cam_world, points_world[i], pixels[i]);
    if (passesReprojectionTest(e2, sigma2, params.chi2Threshold)) {
      result.inliers[i] = true;
      ++result.numInliers;
      sumSq += e2;
    }
  }
  result.rmsReprojectionError = result.numInliers > 0 ? std::sqrt(sumSq / result.numInliers) : 0.0;
  std::ostringstream info;
  info << result.numInliers << " of " << n << " inliers, rms " << result.rmsReprojectionError << " px";
  if (result.numInliers < params.minInliers) {
    return fail(PnpFailure::TooFewInliers, info.str() + ", need " + std::to_string(params.minInliers));
  }
  result.success = true;
  result.message = info.str();
  return result;
}

}  // namespace pslam::geometry
