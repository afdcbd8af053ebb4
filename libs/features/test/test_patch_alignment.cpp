// alignPatch: recovers a known affine motion's translation to a small fraction of a pixel from starts a pixel off,
// rejects a wrong patch, a warp outside the accepted scale and patches off the image; ScalePyramid level coordinates
// invert each other and follow the resize's pixel-centre convention; patchWarpOf gives an affine transfer exactly
// and no warp where a pixel does not project.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>

#include <opencv2/imgproc.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/DirectPointSelector.h"
#include "pslam/features/PatchAlignment.h"

using namespace pslam::features;
using pslam::features::test::texturedImage;

namespace {

struct WarpedPair {
  cv::Mat image1, image2;
  Eigen::Matrix2d A;
  Eigen::Vector2d t;
  std::vector<Eigen::Vector2d> points;  ///< textured points of image 1 whose warped patch stays inside image 2
  Eigen::Vector2d map(const Eigen::Vector2d& x1) const { return A * x1 + t; }
};

/// image2(A x + t) = image1(x): a rotation by `angleDeg` and a scale change `scale` (forward motion), plus a
/// sub-pixel translation.
WarpedPair warpedPair(double angleDeg, double scale) {
  WarpedPair w;
  w.image1 = texturedImage(400, 300, 77);
  const double a = angleDeg * M_PI / 180.0;
  w.A << scale * std::cos(a), -scale * std::sin(a), scale * std::sin(a), scale * std::cos(a);
  const Eigen::Vector2d centre(200, 150);
  w.t = centre - w.A * centre + Eigen::Vector2d(1.37, -0.61);
  const cv::Matx23d M(w.A(0, 0), w.A(0, 1), w.t.x(), w.A(1, 0), w.A(1, 1), w.t.y());
  cv::warpAffine(w.image1, w.image2, M, w.image1.size(), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  DirectSelectorParams p;
  p.targetPoints = 300;
  for (const auto& d : DirectPointSelector(p).select(w.image1)) {
    const Eigen::Vector2d x1(d.pixel.x, d.pixel.y), x2 = w.map(x1);
    if (x1.minCoeff() > 20 && x1.x() < 380 && x1.y() < 280 && x2.minCoeff() > 20 && x2.x() < 380 && x2.y() < 280)
      w.points.push_back(x1);
  }
  return w;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST(PatchAlignment, RecoversAKnownAffineMotionFromAStartAPixelOff) {
  for (const auto& [angle, scale] : {std::pair{0.0, 1.0}, std::pair{8.0, 1.15}, std::pair{-5.0, 0.9}}) {
    SCOPED_TRACE("angle " + std::to_string(angle) + " scale " + std::to_string(scale));
    const WarpedPair w = warpedPair(angle, scale);
    ASSERT_GT(w.points.size(), 100u);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> off(-1.0, 1.0);
    PatchAlignmentParams params;
    std::vector<double> before, after;
    int accepted = 0;
    for (const Eigen::Vector2d& x1 : w.points) {
      const Eigen::Vector2d truth = w.map(x1), start = truth + Eigen::Vector2d(off(rng), off(rng));
      const PatchAlignmentResult r = alignPatch(w.image1, x1, w.A, w.image2, start, params);
      if (!r.accepted) continue;
      ++accepted;
      before.push_back((start - truth).norm());
      after.push_back((r.position - truth).norm());
      EXPECT_GE(r.zncc, params.minZncc);
      EXPECT_LE((r.position - start).norm(), params.maxShift);
    }
    EXPECT_GE(accepted, 0.8 * w.points.size());
    EXPECT_GT(median(before), 0.5);
    std::printf("median error before %.3f after %.3f px\n", median(before), median(after));
    EXPECT_LT(median(after), 0.08);  // the two resamplings (warpAffine, bilinear) limit it, not the alignment
  }
}

TEST(PatchAlignment, AWrongWarpOrAWrongPatchIsNotAccepted) {
  const WarpedPair w = warpedPair(8.0, 1.15);
  PatchAlignmentParams params;
  int acceptedElsewhere = 0, acceptedWrongWarp = 0;
  for (const Eigen::Vector2d& x1 : w.points) {
    // A patch 25 px away along x: another piece of texture.
    const Eigen::Vector2d wrong = w.map(x1) + Eigen::Vector2d(25, 0);
    if (wrong.x() < 370 && alignPatch(w.image1, x1, w.A, w.image2, wrong, params).accepted) ++acceptedElsewhere;
    // The warp rotated by 90 degrees: the patch does not correlate with the image around the truth.
    Eigen::Matrix2d R90;
    R90 << 0, -1, 1, 0;
    if (alignPatch(w.image1, x1, w.A * R90, w.image2, w.map(x1), params).accepted) ++acceptedWrongWarp;
  }
  EXPECT_LT(acceptedElsewhere, 0.05 * w.points.size());
  EXPECT_LT(acceptedWrongWarp, 0.2 * w.points.size());
  // A warp that changes the area by more than maxWarpScale is refused outright, as is a patch off the image.
  const Eigen::Vector2d x1 = w.points.front();
  EXPECT_FALSE(alignPatch(w.image1, x1, 1.5 * w.A, w.image2, w.map(x1), params).accepted);
  EXPECT_EQ(alignPatch(w.image1, x1, 1.5 * w.A, w.image2, w.map(x1), params).iterations, 0);
  EXPECT_FALSE(alignPatch(w.image1, x1, w.A, w.image2, Eigen::Vector2d(2, 2), params).accepted);
  EXPECT_FALSE(alignPatch(w.image1, Eigen::Vector2d(1, 1), w.A, w.image2, w.map(x1), params).accepted);
}

TEST(PatchAlignment, PyramidLevelCoordinatesFollowTheResize) {
  const cv::Mat img = texturedImage(640, 480, 3);
  const ScalePyramid p(img, {1.0, 1.2, 1.44, 1.728});
  ASSERT_EQ(p.numLevels(), 4);
  EXPECT_EQ(p.level(0).data, img.data);  // level 0 is the image itself
  EXPECT_EQ(p.level(1).cols, 533);
  EXPECT_EQ(p.level(1).rows, 400);
  const Eigen::Vector2d x(123.25, 301.5);
  for (int l = 0; l < p.numLevels(); ++l) EXPECT_LT((p.toLevel0(p.toLevel(x, l), l) - x).norm(), 1e-12);
  // Pixel centres: level pixel 0 covers level-0 pixels [0, ratio), its centre is at (ratio - 1) / 2.
  const double ratio = 640.0 / 533.0;
  EXPECT_NEAR(p.toLevel0(Eigen::Vector2d(0, 0), 1).x(), (ratio - 1) / 2, 1e-12);
  // A patch of the coarse level aligns to the same patch of level 0 scaled: the coordinate maps agree with the
  // pixels the resize produced.
  DirectSelectorParams sp;
  sp.targetPoints = 200;
  std::vector<double> err;
  for (const auto& d : DirectPointSelector(sp).select(p.level(2))) {
    const Eigen::Vector2d c2(d.pixel.x, d.pixel.y);
    if (c2.minCoeff() < 15 || c2.x() > p.level(2).cols - 15 || c2.y() > p.level(2).rows - 15) continue;
    const Eigen::Vector2d truth = p.toLevel(p.toLevel0(c2, 2), 1);
    const Eigen::Matrix2d A = Eigen::Matrix2d::Identity() * (p.level(1).cols / double(p.level(2).cols));
    const PatchAlignmentResult r = alignPatch(p.level(2), c2, A, p.level(1), truth + Eigen::Vector2d(0.6, -0.5), {});
    if (r.accepted) err.push_back((r.position - truth).norm());
  }
  ASSERT_GT(err.size(), 50u);
  EXPECT_LT(median(err), 0.1);
}

TEST(PatchAlignment, BadInputIsRefused) {
  EXPECT_THROW(ScalePyramid(cv::Mat(), {1.0}), pslam::Error);
  EXPECT_THROW(ScalePyramid(cv::Mat(10, 10, CV_8UC3), {1.0}), pslam::Error);
  EXPECT_THROW(ScalePyramid(cv::Mat(10, 10, CV_8UC1), {0.5}), pslam::Error);
  const cv::Mat img = texturedImage(100, 100, 1);
  EXPECT_THROW(alignPatch(cv::Mat(100, 100, CV_32F), {50, 50}, Eigen::Matrix2d::Identity(), img, {50, 50}, {}),
               pslam::Error);
  // A NaN start is a patch off the image, not a crash.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(alignPatch(img, {50, 50}, Eigen::Matrix2d::Identity(), img, {nan, 50}, {}).accepted);
}

TEST(PatchAlignment, PatchWarpOfAnAffineTransferIsThatAffineMap) {
  const WarpedPair w = warpedPair(12.0, 1.3);
  const PixelTransfer transfer = [&](const Eigen::Vector2d& x) -> std::optional<Eigen::Vector2d> { return w.map(x); };
  const Eigen::Vector2d centre(123.4, 87.6);
  const std::optional<PatchWarp> warp = patchWarpOf(transfer, centre, 4.0);
  ASSERT_TRUE(warp.has_value());
  EXPECT_LT((warp->centre - w.map(centre)).norm(), 1e-12);
  EXPECT_LT((warp->A - w.A).norm(), 1e-12);
  // A transfer of a plane seen in perspective (a homography): the forward difference over the step is the secant
  // of the map, which the patch of that half side sees, not its derivative at the centre.
  const auto homography = [](const Eigen::Vector2d& x) -> std::optional<Eigen::Vector2d> {
    const double s = 1.0 + 0.002 * x.x();
    if (!(s > 0)) return std::nullopt;
    return Eigen::Vector2d(x.x() / s, x.y() / s);
  };
  const std::optional<PatchWarp> secant = patchWarpOf(homography, centre, 4.0);
  ASSERT_TRUE(secant.has_value());
  EXPECT_NEAR(secant->A(0, 0), ((*homography(centre + Eigen::Vector2d(4, 0))).x() - secant->centre.x()) / 4, 1e-12);
  EXPECT_NEAR(secant->A(1, 1), 1.0 / (1.0 + 0.002 * centre.x()), 1e-12);
  // A pixel that does not project (the plane behind the camera) gives no warp; a step <= 0 is refused.
  EXPECT_FALSE(patchWarpOf(homography, Eigen::Vector2d(-500, 0), 4.0).has_value());
  const auto projectsAboveRow90 = [&](const Eigen::Vector2d& x) -> std::optional<Eigen::Vector2d> {
    if (x.y() > 90) return std::nullopt;
    return w.map(x);
  };
  EXPECT_FALSE(patchWarpOf(projectsAboveRow90, centre, 4.0).has_value());  // only the y step fails
  EXPECT_THROW(patchWarpOf(transfer, centre, 0.0), pslam::Error);
}
