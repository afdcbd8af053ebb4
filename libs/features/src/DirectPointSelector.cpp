#include "pslam/features/DirectPointSelector.h"

#include <algorithm>
#include <cmath>

#include <mrpt/config/CConfigFileBase.h>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::features {

PSLAM_DEFINE_PARAMS(DirectSelectorParams)

DirectPointSelector::DirectPointSelector(const DirectSelectorParams& params) : params_(params) { params_.check(); }

namespace {

/// Largest value of p[0..n), n >= 1. Four lanes at a time where the CPU has them (128-bit universal intrinsics):
/// the selection scans every pixel once per block size it tries, so this loop is most of its time.
float segmentMax(const float* p, int n) {
  int x = 0;
  float m = p[0];
#if CV_SIMD128
  if (n >= 4) {
    cv::v_float32x4 v = cv::v_load(p);
    for (x = 4; x + 4 <= n; x += 4) v = cv::v_max(v, cv::v_load(p + x));
    m = cv::v_reduce_max(v);
  }
#endif
  for (; x < n; ++x) m = std::max(m, p[x]);
  return m;
}

/// The best pixel of a block: the largest gradient, and among equal ones the first in row-major order (the one a
/// row-major scan with a strict comparison keeps).
struct BlockBest {
  float value = -1.f;  // gradients are >= 0: any pixel beats the empty block
  int x = 0, y = 0;
};

bool isBetter(const BlockBest& a, const BlockBest& b) {
  return a.value > b.value || (a.value == b.value && (a.y < b.y || (a.y == b.y && a.x < b.x)));
}

}  // namespace

cv::Mat DirectPointSelector::gradientMagnitude(const cv::Mat& grey) {
  require(!grey.empty() && grey.type() == CV_8UC1, "DirectPointSelector::gradientMagnitude",
          "image must be a non-empty CV_8UC1");
  // Central differences (I(x+1) - I(x-1)) / 2: with integer grey levels the squared magnitude
  // (dx^2 + dy^2) / 4 is exact in float, so the square root is the correctly rounded |grad I| (the same bits as
  // Sobel(ksize 1, scale 0.5) followed by cv::magnitude, without their two gradient images).
  cv::Mat mag(grey.size(), CV_32FC1, cv::Scalar(0));
  for (int y = 1; y + 1 < grey.rows; ++y) {
    const uchar* up = grey.ptr<uchar>(y - 1);
    const uchar* row = grey.ptr<uchar>(y);
    const uchar* down = grey.ptr<uchar>(y + 1);
    float* out = mag.ptr<float>(y);
    for (int x = 1; x + 1 < grey.cols; ++x) {
      const int dx = row[x + 1] - row[x - 1], dy = down[x] - up[x];
      out[x] = 0.25f * static_cast<float>(dx * dx + dy * dy);
    }
  }
  cv::sqrt(mag, mag);
  // The outermost ring has no two-sided difference and stays 0: it is never selected.
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

  // One scan finds the best pixel of every W block (blocks aligned at (x0, y0)); the best pixel of a 2W or 4W
  // block is the best of its W blocks' ones.
  const int nx = (x1 - x0 + W - 1) / W, ny = (y1 - y0 + W - 1) / W;
  std::vector<BlockBest> cells(static_cast<std::size_t>(nx) * ny);
  std::vector<float> rowMax(static_cast<std::size_t>(nx) * W);  // [i * W + r]: row r of the band's block i
  for (int j = 0; j < ny; ++j) {
    const int by = y0 + j * W, rows = std::min(W, y1 - by);
    for (int r = 0; r < rows; ++r) {
      const float* row = grad.ptr<float>(by + r);
      for (int i = 0; i < nx; ++i) {
        const int bx = x0 + i * W;
        rowMax[static_cast<std::size_t>(i) * W + r] = segmentMax(row + bx, std::min(W, x1 - bx));
      }
    }
    // The first row holding the block's maximum, then the first pixel of it in that row.
    for (int i = 0; i < nx; ++i) {
      const float* m = &rowMax[static_cast<std::size_t>(i) * W];
      const int r = static_cast<int>(std::max_element(m, m + rows) - m);
      const float* row = grad.ptr<float>(by + r);
      int x = x0 + i * W;
      const int last = std::min(x + W, x1) - 1;  // bounded: a NaN maximum (bad input) equals no pixel
      while (x < last && row[x] != m[r]) ++x;
      cells[static_cast<std::size_t>(j) * nx + i] = {m[r], x, by + r};
    }
  }
  // Best of the W blocks [i0, i0 + n) x [j0, j0 + n) (clipped to the grid).
  auto bestOfCells = [&](int i0, int j0, int n) {
    BlockBest best;
    for (int j = j0; j < std::min(j0 + n, ny); ++j)
      for (int i = i0; i < std::min(i0 + n, nx); ++i)
        if (isBetter(cells[static_cast<std::size_t>(j) * nx + i], best)) best = cells[static_cast<std::size_t>(j) * nx + i];
    return best;
  };
  // The block [bx, bx+w) x [by, by+w) qualifies when its best pixel exceeds the block mean + d (Algorithm 3, lines
  // 10-16).
  auto take = [&](int bx, int by, int w, float d, const BlockBest& best, int level) {
    const int ex = std::min(bx + w, x1), ey = std::min(by + w, y1);
    const double sum = integral.at<double>(ey, ex) - integral.at<double>(by, ex) - integral.at<double>(ey, bx) +
                       integral.at<double>(by, bx);
    const float threshold = static_cast<float>(sum / ((ex - bx) * (ey - by))) + d;
    if (!(best.value > threshold)) return false;
    DirectPoint p;
    p.pixel = {best.x, best.y};
    p.gradient = best.value;
    p.blockLevel = level;
    out.push_back(p);
    return true;
  };

  // DSO's hierarchy: a 2W block contributes only if none of its W blocks did, a 4W block only if none of its 2W
  // blocks did, with thresholds decreasing with the block size; this fills weakly textured regions sparsely
  // instead of leaving them empty.
  for (int J = 0; J < ny; J += 4)
    for (int I = 0; I < nx; I += 4) {
      bool any4 = false;
      for (int j2 = J; j2 < std::min(J + 4, ny); j2 += 2)
        for (int i2 = I; i2 < std::min(I + 4, nx); i2 += 2) {
          bool any2 = false;
          for (int j = j2; j < std::min(j2 + 2, ny); ++j)
            for (int i = i2; i < std::min(i2 + 2, nx); ++i)
              any2 = take(x0 + i * W, y0 + j * W, W, delta[0], cells[static_cast<std::size_t>(j) * nx + i], 0) || any2;
          if (!any2) any2 = take(x0 + i2 * W, y0 + j2 * W, 2 * W, delta[1], bestOfCells(i2, j2, 2), 1);
          any4 = any4 || any2;
        }
      if (!any4) take(x0 + I * W, y0 + J * W, 4 * W, delta[2], bestOfCells(I, J, 4), 2);
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
