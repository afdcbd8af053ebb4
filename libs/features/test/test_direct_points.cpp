// DirectPointSelector (thesis Algorithm 3): points lie on gradients, satisfy the block threshold and are block
// maxima (brute force), cover weak-contrast regions, approach the target count; determinism and errors.
#include <gtest/gtest.h>

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
