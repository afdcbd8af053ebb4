#include "pslam/features/DirectMatching.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/video/tracking.hpp>

#include "pslam/core/Error.h"

namespace pslam::features {

void DirectMatchParams::check() const {
  const std::string ctx = "DirectMatchParams";
  require(windowSize >= 3 && windowSize % 2 == 1, ctx, "windowSize must be odd and >= 3");
  require(pyramidLevels >= 0, ctx, "pyramidLevels must be >= 0");
  require(maxIterations >= 1, ctx, "maxIterations must be >= 1");
  require(epsilon > 0, ctx, "epsilon must be > 0");
  require(maxForwardBackward > 0, ctx, "maxForwardBackward must be > 0");
  require(maxEpipolarDistance > 0, ctx, "maxEpipolarDistance must be > 0");
}

double epipolarDistance(const cv::Matx33d& F21, const cv::Point2f& x1, const cv::Point2f& x2) {
  const cv::Vec3d line = F21 * cv::Vec3d(x1.x, x1.y, 1.0);  // a x + b y + c = 0 in image 2
  const double norm = std::hypot(line[0], line[1]);
  if (norm <= 0) return std::numeric_limits<double>::infinity();
  return std::abs(line[0] * x2.x + line[1] * x2.y + line[2]) / norm;
}

std::vector<DirectMatch> matchDirectPoints(const cv::Mat& image1, const cv::Mat& image2,
                                           const std::vector<cv::Point2f>& points1,
                                           const std::vector<cv::Point2f>& guesses2, const cv::Matx33d* F21,
                                           const DirectMatchParams& params) {
  const char* ctx = "matchDirectPoints";
  params.check();
  require(!image1.empty() && !image2.empty(), ctx, "empty image");
  require(image1.type() == CV_8UC1 && image2.type() == CV_8UC1, ctx, "images must be CV_8UC1");
  require(image1.size() == image2.size(), ctx, "images differ in size");
  require(guesses2.empty() || guesses2.size() == points1.size(), ctx, "guesses2 must be empty or match points1");
  for (const auto& p : points1) require(std::isfinite(p.x) && std::isfinite(p.y), ctx, "non-finite point");

  std::vector<DirectMatch> out(points1.size());
  if (points1.empty()) return out;
  const cv::Size win(params.windowSize, params.windowSize);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, params.maxIterations, params.epsilon);

  // Each image's pyramid (with the first image's and, for the backward pass, the second's gradients) is built
  // once for both passes; calcOpticalFlowPyrLK would build both for each call. LK tracks every point on its own,
  // so the results are those of two calls on the images.
  std::vector<cv::Mat> pyramid1, pyramid2;
  const int levels1 = cv::buildOpticalFlowPyramid(image1, pyramid1, win, params.pyramidLevels, true);
  const int levels2 = cv::buildOpticalFlowPyramid(image2, pyramid2, win, params.pyramidLevels, true);
  const int levels = std::min(levels1, levels2);

  std::vector<cv::Point2f> forward = guesses2.empty() ? points1 : guesses2;
  std::vector<uchar> okF;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(pyramid1, pyramid2, points1, forward, okF, err, win, levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  // Only what the forward pass and the epipolar check keep is tracked back.
  std::vector<std::size_t> candidates;
  for (size_t i = 0; i < points1.size(); ++i) {
    DirectMatch& m = out[i];
    m.position = forward[i];
    if (!okF[i]) continue;
    bool candidate = m.position.x >= 0 && m.position.y >= 0 && m.position.x <= image2.cols - 1 &&
                     m.position.y <= image2.rows - 1;
    if (F21) {
      m.epipolarDistance = static_cast<float>(epipolarDistance(*F21, points1[i], m.position));
      candidate = candidate && m.epipolarDistance <= params.maxEpipolarDistance;
    }
    if (candidate) candidates.push_back(i);
  }
  if (candidates.empty()) return out;
  // Forward-backward check: tracking the result back must return to the start (rejects occlusions and
  // drifting on edges, where LK is only constrained along the gradient).
  std::vector<cv::Point2f> from2, backward;
  from2.reserve(candidates.size());
  backward.reserve(candidates.size());
  for (std::size_t i : candidates) {
    from2.push_back(forward[i]);
    backward.push_back(points1[i]);
  }
  std::vector<uchar> okB;
  cv::calcOpticalFlowPyrLK(pyramid2, pyramid1, from2, backward, okB, err, win, levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (!okB[k]) continue;
    DirectMatch& m = out[candidates[k]];
    m.forwardBackwardError = static_cast<float>(cv::norm(backward[k] - points1[candidates[k]]));
    m.valid = m.forwardBackwardError <= params.maxForwardBackward;
  }
  return out;
}

}  // namespace pslam::features
