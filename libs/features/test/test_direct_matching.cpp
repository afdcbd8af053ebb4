// matchDirectPoints: sub-pixel LK tracking against a known shift, epipolar and forward-backward rejection,
// epipolar distance against geometry; the same matches as two plain optical-flow calls; bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/DirectMatching.h"
#include "pslam/features/DirectPointSelector.h"

using namespace pslam::features;
using pslam::features::test::texturedImage;

namespace {
struct Scene {
  cv::Mat img1, img2;
  std::vector<cv::Point2f> pts;
  cv::Point2f shift{3.3f, -2.1f};
};
Scene shiftedScene() {
  Scene s;
  s.img1 = texturedImage(400, 300, 51);
  const cv::Matx23d M(1, 0, s.shift.x, 0, 1, s.shift.y);
  cv::warpAffine(s.img1, s.img2, M, s.img1.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  DirectSelectorParams p;
  p.targetPoints = 400;
  for (const auto& d : DirectPointSelector(p).select(s.img1))
    if (d.pixel.x > 20 && d.pixel.y > 20 && d.pixel.x < 380 && d.pixel.y < 280) s.pts.emplace_back(d.pixel);
  return s;
}
}  // namespace

TEST(DirectMatching, TracksAKnownSubPixelShift) {
  const Scene s = shiftedScene();
  ASSERT_GT(s.pts.size(), 150u);
  const auto m = matchDirectPoints(s.img1, s.img2, s.pts);
  ASSERT_EQ(m.size(), s.pts.size());
  std::vector<double> err;
  for (size_t i = 0; i < m.size(); ++i)
    if (m[i].valid) err.push_back(cv::norm(m[i].position - (s.pts[i] + s.shift)));
  EXPECT_GE(err.size(), 0.9 * s.pts.size());
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.05);       // bilinear resampling limits the accuracy, not LK
  EXPECT_LT(err[err.size() * 9 / 10], 0.3);
  for (const auto& x : m) EXPECT_EQ(x.epipolarDistance, -1.f);
}

TEST(DirectMatching, EpipolarCheckRejectsMatchesOffTheLine) {
  const Scene s = shiftedScene();
  // Pure sideways camera motion (rectified pair): epipolar lines are the rows, x2^T F x1 = y1 - y2 = 0.
  const cv::Matx33d F(0, 0, 0, 0, 0, -1, 0, 1, 0);
  DirectMatchParams strict;
  strict.maxEpipolarDistance = 1.5f;  // the 2.1 px vertical shift is off the line
  DirectMatchParams tolerant;
  tolerant.maxEpipolarDistance = 3.0f;  // pose error tolerance covering it
  const auto a = matchDirectPoints(s.img1, s.img2, s.pts, {}, &F, strict);
  const auto b = matchDirectPoints(s.img1, s.img2, s.pts, {}, &F, tolerant);
  size_t validA = 0, validB = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    validA += a[i].valid;
    validB += b[i].valid;
    if (b[i].valid) {
      EXPECT_NEAR(b[i].epipolarDistance, 2.1, 0.3);
    }
  }
  EXPECT_EQ(validA, 0u);
  EXPECT_GE(validB, 0.9 * s.pts.size());
}

TEST(DirectMatching, EpipolarDistanceIsPointToLineDistance) {
  const cv::Matx33d F(1e-6, -2e-5, 3e-3, 4e-5, 2e-6, -5e-3, -2e-3, 6e-3, 1.0);
  const cv::Point2f x1(120, 80), x2(300, 200);
  const cv::Vec3d l = F * cv::Vec3d(x1.x, x1.y, 1);
  // Closest point on the line by brute force along its direction.
  const cv::Point2d dir(-l[1], l[0]);
  const cv::Point2d onLine = std::abs(l[1]) > std::abs(l[0]) ? cv::Point2d(0, -l[2] / l[1]) : cv::Point2d(-l[2] / l[0], 0);
  double best = 1e18;
  for (double t = -5000; t <= 5000; t += 0.01) {
    const cv::Point2d q = onLine + t * dir * (1.0 / std::hypot(dir.x, dir.y));
    best = std::min(best, std::hypot(q.x - x2.x, q.y - x2.y));
  }
  EXPECT_NEAR(epipolarDistance(F, x1, x2), best, 1e-2);
}

TEST(DirectMatching, ForwardBackwardRejectsOccludedPoints) {
  Scene s = shiftedScene();
  s.img2(cv::Rect(100, 80, 120, 100)).setTo(128);  // an occluder without texture
  const auto m = matchDirectPoints(s.img1, s.img2, s.pts);
  size_t inside = 0, rejected = 0;
  for (size_t i = 0; i < m.size(); ++i) {
    const cv::Point2f q = s.pts[i] + s.shift;
    if (q.x < 115 || q.y < 95 || q.x > 205 || q.y > 165) continue;  // well inside the occluder
    ++inside;
    rejected += !m[i].valid;
  }
  ASSERT_GT(inside, 10u);
  EXPECT_GE(rejected, 0.8 * inside);
}

TEST(DirectMatching, RejectsBadInput) {
  const cv::Mat a(50, 50, CV_8UC1, cv::Scalar(0)), b(40, 50, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(matchDirectPoints(a, b, {{1, 1}}), pslam::Error);
  EXPECT_THROW(matchDirectPoints(a, cv::Mat(), {{1, 1}}), pslam::Error);
  EXPECT_THROW(matchDirectPoints(a, a, {{1, 1}}, {{1, 1}, {2, 2}}), pslam::Error);
  EXPECT_THROW(matchDirectPoints(a, a, {{NAN, 1}}), pslam::Error);
  DirectMatchParams bad;
  bad.windowSize = 4;
  EXPECT_THROW(matchDirectPoints(a, a, {{1, 1}}, {}, nullptr, bad), pslam::Error);
  EXPECT_TRUE(matchDirectPoints(a, a, {}).empty());
}

TEST(DirectMatching, SameMatchesAsTwoPlainOpticalFlowCalls) {
  // matchDirectPoints builds each pyramid once and tracks back only what the forward pass and the epipolar check
  // keep. LK tracks every point on its own, so this must be exactly what the plain form gives: both images'
  // pyramids built by each calcOpticalFlowPyrLK call, every point tracked back. The scene makes every check fail
  // somewhere: an occluder (forward-backward), points leaving the image (bounds), a tolerance at the 2.1 px
  // vertical shift (epipolar).
  Scene s = shiftedScene();
  s.img2(cv::Rect(100, 80, 120, 100)).setTo(128);
  for (float x : {30.f, 150.f, 300.f}) s.pts.emplace_back(x, 1.0f);  // moved to y = -1.1: out of the image
  const cv::Matx33d F(0, 0, 0, 0, 0, -1, 0, 1, 0);
  DirectMatchParams params;
  params.maxEpipolarDistance = 2.1f;
  const std::vector<DirectMatch> m = matchDirectPoints(s.img1, s.img2, s.pts, {}, &F, params);

  const cv::Size win(params.windowSize, params.windowSize);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, params.maxIterations, params.epsilon);
  std::vector<cv::Point2f> forward = s.pts, backward = s.pts;
  std::vector<uchar> okF, okB;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(s.img1, s.img2, s.pts, forward, okF, err, win, params.pyramidLevels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(s.img2, s.img1, forward, backward, okB, err, win, params.pyramidLevels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  ASSERT_EQ(m.size(), s.pts.size());
  std::size_t valid = 0, failedEpipolar = 0, failedBackward = 0, outside = 0;
  for (std::size_t i = 0; i < s.pts.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    const cv::Point2f q = forward[i];
    const bool inside = q.x >= 0 && q.y >= 0 && q.x <= s.img2.cols - 1 && q.y <= s.img2.rows - 1;
    const bool onLine = epipolarDistance(F, s.pts[i], q) <= params.maxEpipolarDistance;
    const bool consistent = cv::norm(backward[i] - s.pts[i]) <= params.maxForwardBackward;
    const bool expected = okF[i] && okB[i] && inside && onLine && consistent;
    EXPECT_EQ(m[i].valid, expected);
    EXPECT_EQ(m[i].position, q);
    if (expected) EXPECT_EQ(m[i].forwardBackwardError, static_cast<float>(cv::norm(backward[i] - s.pts[i])));
    valid += expected;
    failedEpipolar += okF[i] && inside && !onLine;
    failedBackward += okF[i] && inside && onLine && (!okB[i] || !consistent);
    outside += !okF[i] || !inside;
  }
  // Every branch taken (counts of this seeded scene: the occluder's points mostly leave the epipolar band first).
  EXPECT_GT(valid, 20u);
  EXPECT_GT(failedEpipolar, 20u);
  EXPECT_GE(failedBackward, 2u);
  EXPECT_GE(outside, 3u);
  std::printf("valid %zu, epipolar %zu, backward %zu, outside %zu of %zu\n", valid, failedEpipolar, failedBackward,
              outside, s.pts.size());
}
