#include "pslam/features/DirectPointSelector.h"

#include <algorithm>
#include <cmath>

#include <mrpt/config/CConfigFileBase.h>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::features {

PSLAM_DEFINE_PARAMS(DirectSelectorParams)

DirectPointSelector::DirectPointSelector(const DirectSelectorParams& params) : params_(params) { params_.check(); }

cv::Mat DirectPointSelector::gradientMagnitude(const cv::Mat& grey) {
  cv::Mat gx, gy, mag;
  // ksize 1 = [-1 0 1]; scale 0.5 makes it the central difference (I(x+1) - I(x-1)) / 2.
  cv::Sobel(grey, gx, CV_32F, 1, 0, 1, 0.5, 0, cv::BORDER_REPLICATE);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 1, 0.5, 0, cv::BORDER_REPLICATE);
  cv::magnitude(gx, gy, mag);
  // The outermost ring has no two-sided difference: never select it.
  mag.row(0).setTo(0);
  mag.row(mag.rows - 1).setTo(0);
  mag.col(0).setTo(0);
  mag.col(mag.cols - 1).setTo(0);
  return mag;
}

std::vector<DirectPoint> DirectPointSelector::selectWithBlockSize(const cv::Mat& grad, const cv::Mat& integral,
                                                                  int W) const {
  std::vector<DirectPoint> out;
  const int b = params_.border;
  const int x0 = b, y0 = b, x1 = grad.cols - b, y1 = grad.rows - b;  // usable area [x0,x1) x [y0,y1)
  if (x1 <= x0 || y1 <= y0) return out;
  const float delta[3] = {params_.thresholdOffset, params_.thresholdOffset * params_.thresholdDecay,
                          params_.thresholdOffset * params_.thresholdDecay * params_.thresholdDecay};

  // Best pixel of block [bx, bx+w) x [by, by+w) whose gradient exceeds the block mean + delta (Algorithm 3,
  // lines 10-16); returns false if none qualifies.
  auto bestInBlock = [&](int bx, int by, int w, float d, DirectPoint& best) {
    const int ex = std::min(bx + w, x1), ey = std::min(by + w, y1);
    if (ex <= bx || ey <= by) return false;
    const double sum = integral.at<double>(ey, ex) - integral.at<double>(by, ex) - integral.at<double>(ey, bx) +
                       integral.at<double>(by, bx);
    const float threshold = static_cast<float>(sum / ((ex - bx) * (ey - by))) + d;
    bool found = false;
    for (int y = by; y < ey; ++y) {
      const float* row = grad.ptr<float>(y);
      for (int x = bx; x < ex; ++x)
        if (row[x] > threshold && (!found || row[x] > best.gradient)) {
          best.pixel = {x, y};
          best.gradient = row[x];
          found = true;
        }
    }
    return found;
  };

  // DSO's hierarchy: a 2W block contributes only if none of its W blocks did, a 4W block only if none of its 2W
  // blocks did, with thresholds decreasing with the block size; this fills weakly textured regions sparsely
  // instead of leaving them empty.
  for (int Y = y0; Y < y1; Y += 4 * W)
    for (int X = x0; X < x1; X += 4 * W) {
      bool any4 = false;
      for (int y2 = Y; y2 < std::min(Y + 4 * W, y1); y2 += 2 * W)
        for (int x2 = X; x2 < std::min(X + 4 * W, x1); x2 += 2 * W) {
          bool any2 = false;
          for (int y = y2; y < std::min(y2 + 2 * W, y1); y += W)
            for (int x = x2; x < std::min(x2 + 2 * W, x1); x += W) {
              DirectPoint p;
              if (bestInBlock(x, y, W, delta[0], p)) {
                p.blockLevel = 0;
                out.push_back(p);
                any2 = true;
              }
            }
          if (!any2) {
            DirectPoint p;
            if (bestInBlock(x2, y2, 2 * W, delta[1], p)) {
              p.blockLevel = 1;
              out.push_back(p);
              any2 = true;
            }
          }
          any4 = any4 || any2;
        }
      if (!any4) {
        DirectPoint p;
        if (bestInBlock(X, Y, 4 * W, delta[2], p)) {
          p.blockLevel = 2;
          out.push_back(p);
        }
      }
    }
  return out;
}

std::vector<DirectPoint> DirectPointSelector::select(const cv::Mat& image, int targetPoints) const {
  require(!image.empty(), "DirectPointSelector::select", "empty image");
  require(targetPoints > 0, "DirectPointSelector::select", "targetPoints must be > 0");
  require(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3), "DirectPointSelector::select",
          "image must be CV_8UC1 or CV_8UC3 (got type " + std::to_string(image.type()) + ")");
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  const cv::Mat grad = gradientMagnitude(grey);
  cv::Mat integral;
  cv::integral(grad, integral, CV_64F);

  // The count scales with 1/W^2 where blocks are textured: rescale W by sqrt(found/target) until within 15 %,
  // then keep the block size whose count comes closest (W is an integer, so the target is met only roughly).
  const double usableArea = std::max(1.0, double(grey.cols - 2 * params_.border) * (grey.rows - 2 * params_.border));
  int W = params_.initialBlockSize > 0 ? params_.initialBlockSize
                                       : static_cast<int>(std::lround(std::sqrt(usableArea / targetPoints)));
  W = std::max(2, W);
  std::vector<DirectPoint> points = selectWithBlockSize(grad, integral, W);
  auto offBy = [&](size_t n) { return std::abs(static_cast<double>(n) - targetPoints); };
  std::vector<int> tried{W};
  int bestW = W;
  std::vector<DirectPoint> best = points;
  for (int it = 0; it < params_.adaptIterations && !points.empty(); ++it) {
    const double ratio = points.size() / static_cast<double>(targetPoints);
    if (ratio > 0.85 && ratio < 1.15) break;
    int next = std::max(2, static_cast<int>(std::lround(W * std::sqrt(ratio))));
    if (next == W) next = ratio > 1 ? W + 1 : std::max(2, W - 1);
    if (std::find(tried.begin(), tried.end(), next) != tried.end()) break;
    tried.push_back(next);
    W = next;
    points = selectWithBlockSize(grad, integral, W);
    if (offBy(points.size()) < offBy(best.size())) {
      best = points;
      bestW = W;
    }
  }
  // Polish: the neighbouring block sizes of the best one may land closer still.
  for (int w : {bestW - 1, bestW + 1}) {
    if (w < 2 || std::find(tried.begin(), tried.end(), w) != tried.end() || best.empty()) continue;
    tried.push_back(w);
    auto candidate = selectWithBlockSize(grad, integral, w);
    if (offBy(candidate.size()) < offBy(best.size())) {
      best.swap(candidate);
      bestW = w;
    }
  }
  W = bestW;
  points.swap(best);
  lastBlockSize_ = W;
  return points;
}

}  // namespace pslam::features

namespace pslam::features {

std::vector<std::vector<DirectPoint>> DirectPointSelector::selectPyramid(const std::vector<cv::Mat>& levels) const {
  std::vector<std::vector<DirectPoint>> out(levels.size());
  double totalArea = 0;
  for (const cv::Mat& l : levels) {
    require(!l.empty(), "DirectPointSelector::selectPyramid", "empty pyramid level");
    totalArea += l.total();
  }
  for (size_t i = 0; i < levels.size(); ++i) {
    const int target =
        std::max(1, static_cast<int>(std::lround(params_.targetPoints * levels[i].total() / totalArea)));
    out[i] = select(levels[i], target);
  }
  return out;
}

}  // namespace pslam::features
