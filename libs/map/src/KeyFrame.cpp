#include "pslam/map/KeyFrame.h"

#include <cmath>

#include "pslam/core/Error.h"

namespace pslam::map {

void KeyFrame::setPyramid(int numLevels, double scaleFactor) {
  require(numLevels >= 1, "KeyFrame::setPyramid", "numLevels must be >= 1");
  require(std::isfinite(scaleFactor) && scaleFactor >= 1.0, "KeyFrame::setPyramid", "scaleFactor must be >= 1");
  scaleFactors.assign(numLevels, 1.0);
  levelSigma2.assign(numLevels, 1.0);
  for (int l = 1; l < numLevels; ++l) {
    scaleFactors[l] = scaleFactors[l - 1] * scaleFactor;
    levelSigma2[l] = scaleFactors[l] * scaleFactors[l];
  }
}

void KeyFrame::check(const std::string& context) const {
  camera.check(context);
  require(std::isfinite(timestamp), context, "timestamp is NaN or Inf");
  require(T_cam_world.matrix().allFinite(), context, "pose T_cam_world has NaN/Inf entries");
  const Eigen::Matrix3d R = T_cam_world.linear();
  require((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0, context,
          "pose T_cam_world rotation is not orthonormal");
  require(!scaleFactors.empty() && scaleFactors.size() == levelSigma2.size(), context,
          "scaleFactors / levelSigma2 must be non-empty and of equal size (call setPyramid)");
  for (std::size_t l = 0; l < scaleFactors.size(); ++l)
    require(std::isfinite(scaleFactors[l]) && scaleFactors[l] > 0.0 && std::isfinite(levelSigma2[l]) &&
                levelSigma2[l] > 0.0,
            context, "pyramid level " + std::to_string(l) + " has a non-positive scale or sigma^2");
  const std::size_t n = keypoints.size();
  if (n > 0 || !descriptors.empty())
    require(descriptors.rows == static_cast<int>(n) && descriptors.cols == 32 && descriptors.type() == CV_8UC1,
            context,
            "descriptors must be " + std::to_string(n) + " x 32 CV_8U, got " + std::to_string(descriptors.rows) +
                " x " + std::to_string(descriptors.cols) + " type " + std::to_string(descriptors.type()));
  for (std::size_t i = 0; i < n; ++i) {
    const cv::KeyPoint& k = keypoints[i];
    require(std::isfinite(k.pt.x) && std::isfinite(k.pt.y), context,
            "keypoint " + std::to_string(i) + " has a NaN/Inf position");
    require(k.octave >= 0 && k.octave < numLevels(), context,
            "keypoint " + std::to_string(i) + " octave " + std::to_string(k.octave) + " outside the " +
                std::to_string(numLevels()) + "-level pyramid");
  }
  require(semanticProbabilities.empty() || semanticProbabilities.size() == n, context,
          "semanticProbabilities must be empty or one per keypoint");
  for (std::size_t i = 0; i < semanticProbabilities.size(); ++i)
    for (float p : semanticProbabilities[i])
      require(std::isfinite(p) && p >= 0.f && p <= 1.f, context,
              "semantic probability of keypoint " + std::to_string(i) + " outside [0,1]");
}

}  // namespace pslam::map
