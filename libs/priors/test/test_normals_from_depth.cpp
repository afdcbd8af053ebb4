// Normals and planar mask from synthetic depth of known planes (the normal-priors app test is in
// apps/normal-priors).
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include <mrpt/config/CConfigFileMemory.h>

#include "RoomScene.h"
#include "pslam/core/Error.h"
#include "pslam/priors/NormalsFromDepth.h"

using namespace pslam::priors;
using pslam::priors::test::renderRoom;

namespace {

const Eigen::Matrix3d kRoomRotation =
    (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX())).toRotationMatrix();
const Eigen::Vector3d kHalfSize(2.0, 1.3, 3.0);
const Eigen::Vector3d kCamInRoom(0.3, -0.2, -1.0);

struct Stats {
  double planarShare = 0, medianErrDeg = 0, maxErrDeg = 0, p99ErrDeg = 0, shareOver1Deg = 0;
  std::size_t count = 0;
};

Stats compare(const NormalMap& est, const cv::Mat& truth, bool planarOnly) {
  NormalErrorAccumulator acc;
  std::vector<double> errs;
  double maxErr = 0;
  std::size_t planar = 0;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      if (est.planarMask.at<uchar>(v, u)) ++planar;
      if (planarOnly && !est.planarMask.at<uchar>(v, u)) continue;
      const cv::Vec3f n = est.normals.at<cv::Vec3f>(v, u);
      if (n == cv::Vec3f(0, 0, 0)) continue;
      const double e = normalAngleDeg(n, truth.at<cv::Vec3f>(v, u));
      acc.add(e);
      errs.push_back(e);
      maxErr = std::max(maxErr, e);
    }
  Stats s;
  s.planarShare = planar / double(truth.total());
  s.medianErrDeg = acc.summary().medianDeg;
  s.maxErrDeg = maxErr;
  s.count = acc.summary().count;
  std::sort(errs.begin(), errs.end());
  s.p99ErrDeg = errs.empty() ? 180.0 : errs[errs.size() * 99 / 100];
  s.shareOver1Deg = errs.empty() ? 1.0
                                 : double(errs.end() - std::upper_bound(errs.begin(), errs.end(), 1.0)) / errs.size();
  std::cout << "planar share " << s.planarShare << " median " << s.medianErrDeg << " p99 " << s.p99ErrDeg << " max "
            << s.maxErrDeg << " deg, share > 1 deg " << s.shareOver1Deg << " over " << s.count << " px\n";
  return s;
}

}  // namespace

TEST(NormalsFromDepth, NoiseFreeRoomMatchesAnalyticNormals) {
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom);
  const DepthNormalEstimator estimator;
  const NormalMap nm = estimator.compute(scene.depth, scene.K);
  EXPECT_GE(nm.planeCount, 3);
  const Stats planar = compare(nm, scene.normals, true);
  EXPECT_GT(planar.planarShare, 0.9);
  EXPECT_LT(planar.p99ErrDeg, 0.1);  // exact planes: the plane fit is exact up to float rounding
  // Pixels on the fold lines themselves see two walls at once (ambiguous ground truth): one pixel column
  // per fold, well under 1 % of the image.
  EXPECT_LT(planar.shareOver1Deg, 0.01);
  // Per-pixel PCA normals (no plane replacement) away from the edges.
  DepthNormalParams p;
  p.usePlaneNormals = false;
  const Stats pixel = compare(DepthNormalEstimator(p).compute(scene.depth, scene.K), scene.normals, false);
  EXPECT_LT(pixel.medianErrDeg, 0.1);
  // Windows within windowRadius of a fold mix two walls: a band of ~2r px per fold (~5 % of this image).
  EXPECT_LT(pixel.shareOver1Deg, 0.05);
}

TEST(NormalsFromDepth, NoisyQuantizedDepthStillGivesAccuratePlaneNormals) {
  // Kinect-like: 3 mm noise, then stored as TUM u16 (5000 = 1 m).
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom, 0.003, 7);
  cv::Mat raw;
  scene.depth.convertTo(raw, CV_16U, 5000.0);
  const NormalMap nm = DepthNormalEstimator().computeFromRaw(raw, 1.0 / 5000.0, scene.K);
  const Stats planar = compare(nm, scene.normals, true);
  EXPECT_GT(planar.planarShare, 0.7);
  EXPECT_LT(planar.medianErrDeg, 1.0);
  EXPECT_LT(planar.shareOver1Deg, 0.01);
}

TEST(NormalsFromDepth, DepthDiscontinuityDoesNotBlendNormals) {
  // A plane at 2 m facing the camera, with a raised square at 1 m: no normal may tilt across the step.
  cv::Mat depth(240, 320, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(100, 60, 120, 120)).setTo(1.0f);
  const PinholeIntrinsics K{300, 300, 159.5, 119.5};
  DepthNormalParams p;
  p.usePlaneNormals = false;
  p.minPlaneCells = 10;
  const NormalMap nm = DepthNormalEstimator(p).compute(depth, K);
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u) {
      const cv::Vec3f n = nm.normals.at<cv::Vec3f>(v, u);
      if (n == cv::Vec3f(0, 0, 0)) continue;
      ASSERT_LT(normalAngleDeg(n, cv::Vec3f(0, 0, -1)), 1.0) << "pixel " << u << "," << v;
    }
  EXPECT_GE(nm.planeCount, 2);
}

TEST(NormalsFromDepth, RejectsBadInputAndParameters) {
  const DepthNormalEstimator e;
  EXPECT_THROW(e.compute(cv::Mat(), {500, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.compute(cv::Mat(10, 10, CV_64FC1, cv::Scalar(1)), {500, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.compute(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1)), {0, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.computeFromRaw(cv::Mat(10, 10, CV_16UC1, cv::Scalar(1)), 0.0, {500, 500, 5, 5}), pslam::Error);
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("NormalsFromDepth", "cellSize", 1);
  DepthNormalParams p;
  try {
    p.loadFromConfigFile(cfg, "NormalsFromDepth");
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find("cellSize"), std::string::npos);
  }
}
