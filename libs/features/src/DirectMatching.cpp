#include "pslam/features/DirectMatching.h"

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

  std::vector<cv::Point2f> forward = guesses2.empty() ? points1 : guesses2;
  std::vector<uchar> okF, okB;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(image1, image2, points1, forward, okF, err, win, params.pyramidLevels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  // Forward-backward check: tracking the result back must return to the start (rejects occlusions and
  // drifting on edges, where LK is only constrained along the gradient).
  std::vector<cv::Point2f> backward = points1;
  cv::calcOpticalFlowPyrLK(image2, image1, forward, backward, okB, err, win, params.pyramidLevels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  for (size_t i = 0; i < points1.size(); ++i) {
    DirectMatch& m = out[i];
    m.position = forward[i];
    if (!okF[i] || !okB[i]) continue;
    m.forwardBackwardError = static_cast<float>(cv::norm(backward[i] - points1[i]));
    bool valid = m.forwardBackwardError <= params.maxForwardBackward;
    valid = valid && m.position.x >= 0 && m.position.y >= 0 && m.position.x <= image2.cols - 1 &&
            m.position.y <= image2.rows - 1;
    if (F21) {
      m.epipolarDistance = static_cast<float>(epipolarDistance(*F21, points1[i], m.position));
      valid = valid && m.epipolarDistance <= params.maxEpipolarDistance;
    }
    m.valid = valid;
  }
  return out;
}

}  // namespace pslam::features
