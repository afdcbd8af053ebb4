// DirectPointSelector (thesis Algorithm 3): points lie on gradients, satisfy the block threshold and are block
// maxima (brute force), cover weak-contrast regions, approach the target count; determinism and errors.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <set>

#include <mrpt/config/CConfigFileMemory.h>
#include <opencv2/imgproc.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/DirectPointSelector.h"
#include "pslam/features/OrbExtractor.h"

using namespace pslam::features;
using pslam::features::test::texturedImage;

TEST(DirectPoints, FlatImageGivesNothingAndStepEdgeGivesEdgePoints) {
  DirectPointSelector sel;
  EXPECT_TRUE(sel.select(cv::Mat(120, 160, CV_8UC1, cv::Scalar(90))).empty());
  cv::Mat step(120, 160, CV_8UC1, cv::Scalar(50));
  step.colRange(80, 160).setTo(150);
  const auto pts = sel.select(step);
  ASSERT_FALSE(pts.empty());
  for (const auto& p : pts) {
    EXPECT_TRUE(p.pixel.x == 79 || p.pixel.x == 80) << p.pixel;
    EXPECT_NEAR(p.gradient, 50.f, 1e-4);  // central difference of a 100 grey-level step
  }
}

TEST(DirectPoints, LevelZeroPointsAreBlockMaximaAboveTheBlockThreshold) {
  const cv::Mat img = texturedImage(320, 240, 12);
  DirectSelectorParams p;
  DirectPointSelector sel(p);
  const cv::Mat grad = DirectPointSelector::gradientMagnitude(img);
  cv::Mat integral;
  cv::integral(grad, integral, CV_64F);
  const int W = 5;
  const auto pts = sel.selectWithBlockSize(grad, integral, W);
  ASSERT_GT(pts.size(), 100u);
  std::set<std::pair<int, int>> blocksWithPoint;
  for (const auto& pt : pts) {
    EXPECT_FLOAT_EQ(pt.gradient, grad.at<float>(pt.pixel));
    if (pt.blockLevel != 0) continue;
    // Brute force over the W block (aligned at the border) that holds the point.
    const int bx = p.border + (pt.pixel.x - p.border) / W * W, by = p.border + (pt.pixel.y - p.border) / W * W;
    EXPECT_TRUE(blocksWithPoint.insert({bx, by}).second) << "two points in one block";
    double sum = 0;
    float maxGrad = 0;
    int n = 0;
    for (int y = by; y < std::min(by + W, img.rows - p.border); ++y)
      for (int x = bx; x < std::min(bx + W, img.cols - p.border); ++x) {
        sum += grad.at<float>(y, x);
        maxGrad = std::max(maxGrad, grad.at<float>(y, x));
        ++n;
      }
    EXPECT_GT(pt.gradient, sum / n + p.thresholdOffset - 1e-3);
    EXPECT_FLOAT_EQ(pt.gradient, maxGrad);
  }
}

namespace {

// Algorithm 3 spelled out: every block scanned on its own for its best pixel above the block threshold (the
// selector finds all W blocks' best pixels in one scan and combines them for the 2W and 4W blocks).
std::vector<DirectPoint> perBlockScan(const cv::Mat& grad, const cv::Mat& integral, int W, const DirectSelectorParams& p) {
  std::vector<DirectPoint> out;
  const int x0 = p.border, y0 = p.border, x1 = grad.cols - p.border, y1 = grad.rows - p.border;
  const float delta[3] = {p.thresholdOffset, p.thresholdOffset * p.thresholdDecay,
                          p.thresholdOffset * p.thresholdDecay * p.thresholdDecay};
  auto bestInBlock = [&](int bx, int by, int w, int level) {
    const int ex = std::min(bx + w, x1), ey = std::min(by + w, y1);
    const double sum = integral.at<double>(ey, ex) - integral.at<double>(by, ex) - integral.at<double>(ey, bx) +
                       integral.at<double>(by, bx);
    const float threshold = static_cast<float>(sum / ((ex - bx) * (ey - by))) + delta[level];
    DirectPoint best;
    bool found = false;
    for (int y = by; y < ey; ++y)
      for (int x = bx; x < ex; ++x)
        if (grad.at<float>(y, x) > threshold && (!found || grad.at<float>(y, x) > best.gradient)) {
          best.pixel = {x, y};
          best.gradient = grad.at<float>(y, x);
          best.blockLevel = level;
          found = true;
        }
    if (found) out.push_back(best);
    return found;
  };
  for (int Y = y0; Y < y1; Y += 4 * W)
    for (int X = x0; X < x1; X += 4 * W) {
      bool any4 = false;
      for (int y2 = Y; y2 < std::min(Y + 4 * W, y1); y2 += 2 * W)
        for (int x2 = X; x2 < std::min(X + 4 * W, x1); x2 += 2 * W) {
          bool any2 = false;
          for (int y = y2; y < std::min(y2 + 2 * W, y1); y += W)
            for (int x = x2; x < std::min(x2 + 2 * W, x1); x += W) any2 = bestInBlock(x, y, W, 0) || any2;
          if (!any2) any2 = bestInBlock(x2, y2, 2 * W, 1);
          any4 = any4 || any2;
        }
      if (!any4) bestInBlock(X, Y, 4 * W, 2);
    }
  return out;
}

}  // namespace

TEST(DirectPoints, SameBitsAsThePlainGradientAndThePerBlockScan) {
  // Textured, weak-contrast, quantized (many equal gradients: ties inside and between blocks) and odd-sized
  // images, at block sizes that leave clipped blocks at the right and bottom.
  std::vector<cv::Mat> images{texturedImage(640, 480, 21), texturedImage(333, 217, 22)};
  cv::Mat weak = texturedImage(320, 240, 23);
  weak.convertTo(weak, CV_8U, 0.1, 120);
  images.push_back(weak);
  cv::Mat quantized = texturedImage(301, 199, 24);
  quantized.forEach<uchar>([](uchar& v, const int*) { v = static_cast<uchar>(v / 64 * 64); });
  images.push_back(quantized);
  DirectSelectorParams p;
  const DirectPointSelector sel(p);
  for (std::size_t k = 0; k < images.size(); ++k) {
    const cv::Mat& img = images[k];
    cv::Mat gx, gy, plain;
    cv::Sobel(img, gx, CV_32F, 1, 0, 1, 0.5, 0, cv::BORDER_REPLICATE);
    cv::Sobel(img, gy, CV_32F, 0, 1, 1, 0.5, 0, cv::BORDER_REPLICATE);
    cv::magnitude(gx, gy, plain);
    plain.row(0).setTo(0);
    plain.row(plain.rows - 1).setTo(0);
    plain.col(0).setTo(0);
    plain.col(plain.cols - 1).setTo(0);
    const cv::Mat grad = DirectPointSelector::gradientMagnitude(img);
    ASSERT_EQ(grad.type(), CV_32FC1);
    ASSERT_EQ(0, std::memcmp(grad.data, plain.data, plain.total() * sizeof(float))) << "image " << k;
    cv::Mat integral;
    cv::integral(grad, integral, CV_64F);
    for (int W : {2, 3, 5, 7, 12, 16, 41}) {
      const auto got = sel.selectWithBlockSize(grad, integral, W);
      const auto want = perBlockScan(grad, integral, W, p);
      ASSERT_EQ(got.size(), want.size()) << "image " << k << " W " << W;
      for (std::size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].pixel, want[i].pixel) << "image " << k << " W " << W << " point " << i;
        EXPECT_EQ(got[i].gradient, want[i].gradient);
        EXPECT_EQ(got[i].blockLevel, want[i].blockLevel);
      }
    }
  }
}

TEST(DirectPoints, NaNGradientsSelectNothingInTheirBlock) {
  // selectWithBlockSize is public: a gradient image with NaNs (not one gradientMagnitude makes) must neither read
  // past a block nor select there, and gives what the per-block scan gives. The NaNs sit in the last W block (the
  // integral image carries them into every block below and to the right).
  cv::Mat grad = DirectPointSelector::gradientMagnitude(texturedImage(160, 120, 25));
  const int W = 8;  // usable area [4, 156) x [4, 116): the last block is [148, 156) x [108, 116)
  grad(cv::Rect(148, 108, 8, 8)).setTo(std::numeric_limits<float>::quiet_NaN());
  cv::Mat integral;
  cv::integral(grad, integral, CV_64F);
  DirectSelectorParams p;
  const DirectPointSelector sel(p);
  const auto got = sel.selectWithBlockSize(grad, integral, W);
  const auto want = perBlockScan(grad, integral, W, p);
  EXPECT_GT(got.size(), 50u);
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].pixel, want[i].pixel);
    EXPECT_FALSE(got[i].pixel.x >= 148 && got[i].pixel.y >= 108) << got[i].pixel;
  }
}

TEST(DirectPoints, CountApproachesTargetWithTheClosestBlockSize) {
  const cv::Mat img = texturedImage(640, 480, 13);
  for (int target : {1000, 3000, 8000}) {
    DirectSelectorParams p;
    p.targetPoints = target;
    p.initialBlockSize = target == 8000 ? 9 : 0;  // explicit start far from the answer: adaptation must recover
    DirectPointSelector sel(p);
    const auto pts = sel.select(img);
    const int W = sel.lastBlockSize();
    const cv::Mat grad = DirectPointSelector::gradientMagnitude(img);
    cv::Mat integral;
    cv::integral(grad, integral, CV_64F);
    const double off = std::abs(double(pts.size()) - target);
    // Integer block sizes: the neighbouring sizes must not be closer to the target.
    for (int w : {W - 1, W + 1}) {
      if (w < 2) continue;
      EXPECT_LE(off, std::abs(double(sel.selectWithBlockSize(grad, integral, w).size()) - target) + 1e-9)
          << "target " << target << " W " << W << " vs " << w;
    }
    EXPECT_NEAR(double(pts.size()), target, 0.5 * target) << "W " << W;
  }
}

TEST(DirectPoints, WeakContrastRegionsStillGetPoints) {
  // Right half: the same kind of texture at a quarter of the contrast. Region-adaptive thresholds (and the
  // lower thresholds of larger blocks) must still place at least a fifth of all points there.
  cv::Mat img = texturedImage(640, 480, 14);
  cv::Mat right = img.colRange(320, 640);
  right.convertTo(right, CV_8U, 0.25, 96);
  DirectPointSelector sel;
  const auto pts = sel.select(img);
  size_t inRight = 0;
  for (const auto& p : pts) inRight += p.pixel.x >= 320;
  std::cout << inRight << " of " << pts.size() << " points in the weak-contrast half\n";
  EXPECT_GE(inRight, pts.size() / 5);
}

TEST(DirectPoints, DeterministicAndRejectsBadInput) {
  const cv::Mat img = texturedImage(320, 240, 15);
  DirectPointSelector sel;
  const auto a = sel.select(img), b = sel.select(img);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].pixel, b[i].pixel);
  EXPECT_THROW(sel.select(cv::Mat()), pslam::Error);
  EXPECT_THROW(sel.select(cv::Mat(10, 10, CV_32FC1, cv::Scalar(0))), pslam::Error);
  DirectSelectorParams bad;
  bad.initialBlockSize = -1;
  EXPECT_THROW(DirectPointSelector{bad}, pslam::Error);
  bad = DirectSelectorParams();
  bad.thresholdDecay = 0;
  EXPECT_THROW(DirectPointSelector{bad}, pslam::Error);
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("Direct", "targetPoints", 5000);
  DirectSelectorParams q;
  q.loadFromConfigFile(cfg, "Direct");
  EXPECT_EQ(q.targetPoints, 5000);
  cfg.write("Direct", "border", 0);
  EXPECT_THROW(q.loadFromConfigFile(cfg, "Direct"), pslam::Error);
}

TEST(DirectPoints, PyramidLevelsGetAreaProportionalShares) {
  const cv::Mat img = texturedImage(640, 480, 16);
  OrbParams op;
  op.nLevels = 4;
  op.scaleFactor = 1.5;
  OrbExtractor ex(op);
  std::vector<cv::KeyPoint> k;
  cv::Mat d;
  ex.extract(img, k, d);
  DirectSelectorParams p;
  p.targetPoints = 3000;
  DirectPointSelector sel(p);
  const auto perLevel = sel.selectPyramid(ex.pyramid());
  ASSERT_EQ(perLevel.size(), 4u);
  double area = 0;
  for (const auto& l : ex.pyramid()) area += l.total();
  for (size_t l = 0; l < perLevel.size(); ++l) {
    const cv::Mat& level = ex.pyramid()[l];
    const double share = p.targetPoints * level.total() / area;
    // Integer block sizes: counts land within a factor 1.5 of the share (see CountApproachesTarget...).
    EXPECT_NEAR(double(perLevel[l].size()), share, 0.5 * share) << "level " << l;
    for (const auto& pt : perLevel[l]) {
      EXPECT_TRUE(pt.pixel.x >= p.border && pt.pixel.y >= p.border && pt.pixel.x < level.cols - p.border &&
                  pt.pixel.y < level.rows - p.border)
          << "level " << l << " " << pt.pixel;
    }
  }
  EXPECT_THROW(sel.selectPyramid({cv::Mat()}), pslam::Error);
}
