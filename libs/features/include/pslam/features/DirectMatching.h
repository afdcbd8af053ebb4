#pragma once
// Matching of direct (photometric) points between two frames as in thesis §3.2.2: pyramidal Lucas-Kanade
// optical flow (eq. 2.63) from an expected position, a forward-backward consistency check, and an optional
// epipolar check that tolerates pose errors up to a distance in pixels.
#include <vector>

#include <opencv2/core.hpp>

namespace pslam::features {

struct DirectMatchParams {
  int windowSize = 21;               ///< LK window (pixels, odd)
  int pyramidLevels = 3;             ///< LK pyramid levels above the image
  int maxIterations = 30;            ///< LK iterations per level
  double epsilon = 0.01;             ///< LK stop when the update is below this (pixels)
  float maxForwardBackward = 1.0f;   ///< reject if tracking back lands farther than this from the start (px)
  float maxEpipolarDistance = 2.0f;  ///< reject if farther than this from the epipolar line (px), when F is given
  void check() const;
};

struct DirectMatch {
  bool valid = false;
  cv::Point2f position;             ///< tracked position in image 2
  /// |backward(forward(p1)) - p1|; -1 when the point was not tracked back (the forward pass failed, or it left
  /// the image or the epipolar band) or the backward pass failed.
  float forwardBackwardError = -1;
  /// distance of position to the epipolar line F21 p1, for every point the forward pass kept (-1 without F or
  /// when the forward pass failed).
  float epipolarDistance = -1;
};

/// Tracks `points1` of grey image 1 into grey image 2 (both CV_8UC1, same size), starting from `guesses2`
/// (empty = the same positions). With F21 (x2^T F21 x1 = 0, pixels), matches off the epipolar line are rejected.
/// Uses cv::calcOpticalFlowPyrLK. Throws pslam::Error on bad images or size mismatches.
std::vector<DirectMatch> matchDirectPoints(const cv::Mat& image1, const cv::Mat& image2,
                                           const std::vector<cv::Point2f>& points1,
                                           const std::vector<cv::Point2f>& guesses2 = {},
                                           const cv::Matx33d* F21 = nullptr, const DirectMatchParams& params = {});

/// Distance (pixels) of x2 to the epipolar line F21 x1.
double epipolarDistance(const cv::Matx33d& F21, const cv::Point2f& x1, const cv::Point2f& x2);

}  // namespace pslam::features
